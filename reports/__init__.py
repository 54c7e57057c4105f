"""reports: turn a results store into plots, a self-contained ``index.html`` and ``summary.md``.

Examples
--------
>>> import reports
>>> page = reports.build_report("reports/out/quick")        # doctest: +SKIP
>>> print(reports.summary_table("reports/out/quick"))       # doctest: +SKIP
"""
from .build import FORMATS, PLOT_KINDS, build_report, summary_table, write_report
from .store import Store, load_store

__all__ = ["build_report", "write_report", "summary_table", "load_store", "Store", "PLOT_KINDS", "FORMATS"]
