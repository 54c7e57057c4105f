"""Text for each medium: Markdown, a terminal, a CSV cell, each escaped for where it lands.

Store fields are untrusted (a store may come from anybody): a scene name can hold HTML,
Markdown, terminal escape sequences or a spreadsheet formula. Whatever text leaves the
harness goes through the function of its medium, once, where it is written:

* :func:`markdown` - inline Markdown with no raw HTML, links or emphasis from data;
* :func:`terminal` - printable text: control characters (ESC and the C1 controls that
  start terminal sequences) shown as ``\\x1b``-style escapes;
* :func:`csv_cell` - a cell a spreadsheet reads as text, never as a formula.

The tables of each medium (:func:`markdown_table`, :func:`text_table`) escape every cell.

Examples
--------
>>> markdown("<img src=x onerror=alert(1)> | *a* [b](c) _d_ cornell_box")
'&lt;img src=x onerror=alert(1)&gt; \\\\| \\\\*a\\\\* \\\\[b\\\\](c) \\\\_d\\\\_ cornell_box'
>>> terminal("red\\x1b[31m")
'red\\\\x1b[31m'
>>> csv_cell("=HYPERLINK(\\"http://x\\")")
'\\'=HYPERLINK("http://x")'
"""
from __future__ import annotations

import re

__all__ = ["markdown", "terminal", "csv_cell", "markdown_table", "text_table"]

# Markdown's punctuation that can start emphasis, code, links or table cells inside a line
# (the text never starts a line: headings and list items are the caller's); an underscore
# only where it can open or close emphasis, so ``cornell_box`` stays as it is.
_MD_SPECIAL = re.compile(r"([\\`*\[\]|~])|(?<![A-Za-z0-9])_|_(?![A-Za-z0-9])")
# C0 controls but tab, DEL and the C1 controls (0x80-0x9f: CSI, OSC, ...).
_CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f]")
# A leading character a spreadsheet takes as the start of a formula (OWASP's list).
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def markdown(text) -> str:
    """``text`` as inline Markdown that renders as the same characters and nothing more.

    ``&``, ``<`` and ``>`` become entities (no raw HTML), Markdown's punctuation is
    backslash-escaped (no emphasis, links, code or table cells from data), and line
    breaks and control characters become spaces (one paragraph, one table row).
    """
    s = str(text).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    s = _MD_SPECIAL.sub(lambda m: "\\" + m.group(), s)
    return _CONTROL.sub(" ", s.replace("\r", " ").replace("\n", " "))


def terminal(text) -> str:
    """``text`` safe to print: control characters (ESC, the C1 controls, bell, ...) become
    visible ``\\xNN`` escapes, so data cannot move the cursor, retitle the window or hide
    lines. Newlines and tabs are kept."""
    return _CONTROL.sub(lambda m: f"\\x{ord(m.group()):02x}", str(text))


def csv_cell(value):
    """A CSV cell that a spreadsheet shows as text: a string starting with ``= + - @``, a
    tab or a carriage return gets a leading ``'`` (no formula runs when the file is opened).
    Numbers pass unchanged (a negative number is a number, not a formula)."""
    if isinstance(value, str) and value.startswith(_FORMULA_START):
        return "'" + value
    return value


def markdown_table(header, rows) -> str:
    """A GitHub-flavoured Markdown table, every cell through :func:`markdown`.

    Examples
    --------
    >>> print(markdown_table(["a", "b"], [["x|y", 1]]))
    | a | b |
    | --- | --- |
    | x\\|y | 1 |
    """
    lines = ["| " + " | ".join(markdown(h) for h in header) + " |",
             "| " + " | ".join("---" for _ in header) + " |"]
    lines += ["| " + " | ".join(markdown(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def text_table(header, rows) -> str:
    """A fixed-width plain-text table for a terminal, every cell through :func:`terminal`.

    Examples
    --------
    >>> print(text_table(["a", "bb"], [["xyz", 1]]))
    a    bb
    ---  --
    xyz  1
    """
    cols = [[terminal(c) for c in header]] + [[terminal(c) for c in r] for r in rows]
    widths = [max(len(r[i]) for r in cols) for i in range(len(header))]

    def line(r):
        return "  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip()

    return "\n".join([line(cols[0]), "  ".join("-" * w for w in widths)] + [line(r) for r in cols[1:]])
