"""One module per ``rtbench`` subcommand; each defines ``HELP``, ``add_arguments(parser)`` and ``run(args) -> int``."""
