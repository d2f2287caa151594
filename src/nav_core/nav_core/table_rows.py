"""One row of a numeric table (CSV or whitespace text) as floats, naming the column of a field that is not one."""
from __future__ import annotations


def numbers(fields, names) -> list:
    """``fields`` as floats; ValueError naming the column (from ``names``) and the text of the first bad one."""
    try:
        return [float(f) for f in fields]
    except ValueError:
        for name, text in zip(names, fields):
            try:
                float(text)
            except ValueError:
                raise ValueError(f"column {name!r}: {text.strip()!r} is not a number") from None
        raise
