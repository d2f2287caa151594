"""One row of a numeric table (CSV or whitespace text) as floats, naming the column of a field that is not one;
the header's names; a NavSatStatus column checked."""
from __future__ import annotations

import difflib

import numpy as np

BOM = "\ufeff"


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


def header_names(fields) -> list:
    """The header row's column names, stripped (and without the byte-order mark spreadsheet programs write)."""
    names = [f.strip() for f in fields]
    if names and names[0].startswith(BOM):
        names[0] = names[0][len(BOM):].strip()
    return names


def missing_hint(missing, header) -> str:
    """Suggestions for ``missing`` column names from those ``header`` has ('' when none is close)."""
    spare = [h for h in header if h not in missing]
    lower = {h.lower(): h for h in spare}  # a wrong case first, then the closest spelling
    close = {name: [lower[name.lower()]] if name.lower() in lower
             else difflib.get_close_matches(name, spare, n=1, cutoff=0.6) for name in missing}
    return "".join(f" (for {name!r} did you mean {hit[0]!r}?)" for name, hit in close.items() if hit)


def status_column(values, t, source: str):
    """A ``status`` column (NavSatStatus: -1 no fix, 0 fix, 1 SBAS, 2 GBAS) as ints, and the damage text (None
    when every value is one of those): a NaN, a fraction or another number makes that fix -1 (no fix, dropped by
    the filter and counted), named by its time ``t`` (s)."""
    if values is None:
        return None, None
    values = np.asarray(values, dtype=float)
    ok = np.isin(values, (-1.0, 0.0, 1.0, 2.0))
    status = np.where(ok, values, -1.0).astype(int)
    if ok.all():
        return status, None
    k = int(np.flatnonzero(~ok)[0])
    return status, (f"{source}: {int(np.sum(~ok))} fix(es) whose status is not -1, 0, 1 or 2 taken as no fix "
                    f"(first at t = {t[k]:.6g} s: {float(values[k])!r})")
