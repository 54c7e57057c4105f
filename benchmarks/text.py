"""Text for each medium (Markdown, a terminal, a CSV cell), escaped once where it is written: store fields are
untrusted (a scene name can hold HTML, Markdown, terminal escapes or a spreadsheet formula).

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
    """``text`` as inline Markdown that renders as the same characters: entities for ``& < >``,
    Markdown's punctuation escaped, line breaks and control characters as spaces."""
    s = str(text).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
    s = _MD_SPECIAL.sub(lambda m: "\\" + m.group(), s)
    return _CONTROL.sub(" ", s.replace("\r", " ").replace("\n", " "))


def terminal(text) -> str:
    """``text`` safe to print: control characters but newline and tab become visible ``\\xNN``."""
    return _CONTROL.sub(lambda m: f"\\x{ord(m.group()):02x}", str(text))


def csv_cell(value):
    """A CSV cell a spreadsheet shows as text: a string starting a formula gets a leading ``'``,
    and its control characters (but newline and tab) become visible ``\\xNN``, as :func:`terminal`
    writes them (a CSV is also read with ``cat``); numbers pass unchanged.

    >>> csv_cell("a\\x1b[2Jb"), csv_cell(0.5)
    ('a\\\\x1b[2Jb', 0.5)
    """
    if not isinstance(value, str):
        return value
    return ("'" if value.startswith(_FORMULA_START) else "") + terminal(value)


def markdown_table(header, rows) -> str:
    """A GitHub-flavoured Markdown table, every cell through :func:`markdown`.

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
