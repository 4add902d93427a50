"""What an engine shader does with each asset, one module per technique."""
