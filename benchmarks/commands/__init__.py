"""One module per ``rtbench`` subcommand, each with ``HELP``, ``add_arguments(parser)`` and ``run(args) -> int``;
``rtbench`` imports them all to build its parser, so each imports its runners inside ``run`` (start-up time)."""
