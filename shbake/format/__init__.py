"""Assets out: versioned HDF5 (``docs/FORMAT.md``), images, engine exports; atomic writes."""
