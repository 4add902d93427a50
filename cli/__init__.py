"""The ``shbake`` command line: one thin click module per subcommand."""
