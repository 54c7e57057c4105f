"""One module per ``rtbench`` subcommand, each with ``HELP``, ``add_arguments(parser)`` and ``run(args) -> int``.

``rtbench`` imports every command module to build its parser, so a command imports at
module level only what its parser needs, the rest (runners, the report, Mitsuba, Dask)
inside ``run``: start-up time, and one command never pays for another's.
"""
