"""The ``gimbalscope`` command line: one small module per subcommand."""
