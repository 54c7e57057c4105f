"""One module per ``rtbench`` subcommand; each defines ``HELP``, ``add_arguments(parser)`` and ``run(args) -> int``.

Imports inside functions: ``rtbench`` imports every command module to build its parser on
each start (:func:`benchmarks.cli.build_parser`), so a command module imports at module
level only what its parser needs and imports the rest (the runners, the report and its
matplotlib, Mitsuba, Dask) inside ``run`` and the functions it calls: start-up time, and one
command never pays for another's. The rest of the project imports at module level
(``tests/test_architecture.py``).
"""
