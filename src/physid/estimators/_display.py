"""How a result shows itself: a one-line ``repr`` and a notebook table (``_repr_html_``).

Both read the result schema of `physid.estimators.results` (parameters with units and standard
errors, derived quantities, success and message) plus ``fit_percent`` where a result has one.
"""

from __future__ import annotations

import html
import math
from typing import Any

#: Two-sided 95 % quantile of the standard normal: the interval is value ± Z95 · stderr.
Z95 = 1.959963984540054


def _finite(x) -> bool:
    try:
        return x is not None and math.isfinite(float(x))
    except (TypeError, ValueError):
        return False


def fit_text(result) -> str:
    """``"fit 99.46 %"`` (or per channel), or "" when the result has no finite fit.

    Parameters
    ----------
    result : ResultMixin
        Any estimator result.

    Returns
    -------
    str
    """
    fit = getattr(result, "fit_percent", None)
    if isinstance(fit, dict):
        parts = [f"{k} {v:.2f} %" for k, v in fit.items() if _finite(v)]
        return f"fit {', '.join(parts)}" if parts else ""
    return f"fit {float(fit):.2f} %" if _finite(fit) else ""


def _rows(schema: dict[str, Any], derived_se) -> list[tuple[str, float, Any, str, str]]:
    stderr = schema["stderr"] or {}
    rows = []
    for kind, values, errors in (
        ("fitted", schema["parameters"], stderr),
        ("derived", schema["derived"], derived_se or {}),
    ):
        for name, value in values.items():
            se = errors.get(name)
            rows.append((name, float(value), se if _finite(se) else None, kind, ""))
    return [(n, v, se, k, schema["units"].get(n, "")) for n, v, se, k, _ in rows]


def plain_repr(result, schema: dict[str, Any]) -> str:
    """One line: the class, the method, success, each fitted value ± stderr [unit], the fit.

    Parameters
    ----------
    result : ResultMixin
        The result.
    schema : dict
        ``result._schema()``.

    Returns
    -------
    str
        e.g. ``RecursiveResult(rls, success: theta2 = 400.2 ± 0.31 [1/s^2], ...; fit 99.46 %)``.
    """
    stderr = schema["stderr"] or {}
    parts = []
    for name, value in schema["parameters"].items():
        se = stderr.get(name)
        unit = schema["units"].get(name)
        text = f"{name} = {value:.6g}"
        text += f" ± {se:.2g}" if _finite(se) else ""
        text += f" [{unit}]" if unit else ""
        parts.append(text)
    shown = ", ".join(parts[:8]) + (f", … ({len(parts) - 8} more)" if len(parts) > 8 else "")
    method = getattr(result, "method", "") or ""
    status = "success" if schema["success"] else "FAILED"
    head = f"{method}, {status}" if method else status
    tail = fit_text(result)
    return f"{type(result).__name__}({head}: {shown}{'; ' + tail if tail else ''})"


def html_table(result, schema: dict[str, Any]) -> str:
    """An HTML table for notebooks: value, ± stderr, 95 % interval, unit; the fit and message.

    Parameters
    ----------
    result : ResultMixin
        The result.
    schema : dict
        ``result._schema()``.

    Returns
    -------
    str
        A ``<div>`` with a heading line and a ``<table>``; every text is HTML-escaped.
    """
    esc = html.escape
    method = getattr(result, "method", "") or ""
    status = "success" if schema["success"] else "FAILED"
    colour = "#1a7f37" if schema["success"] else "#b42318"
    fit = fit_text(result)
    head = (
        f"<b>{esc(type(result).__name__)}</b> {esc(method)} "
        f"<span style='color:{colour}'>{status}</span>" + (f" · {esc(fit)}" if fit else "")
    )
    body = []
    for name, value, se, kind, unit in _rows(schema, getattr(result, "derived_stderr", None)):
        if se is None:
            se_txt = interval = "—"
        else:
            se_txt = f"± {se:.3g}"
            interval = f"[{value - Z95 * se:.6g}, {value + Z95 * se:.6g}]"
        body.append(
            f"<tr><td>{esc(name)}</td><td style='text-align:right'>{value:.6g}</td>"
            f"<td>{esc(se_txt)}</td><td>{esc(interval)}</td><td>{esc(unit)}</td>"
            f"<td>{esc(kind)}</td></tr>"
        )
    notes = []
    if schema["stderr"] is None and schema["stderr_reason"]:
        notes.append(f"no standard errors: {schema['stderr_reason']}")
    if schema["message"]:
        notes.append(schema["message"])
    foot = "".join(f"<p style='margin:0.2em 0'>{esc(n)}</p>" for n in notes)
    return (
        f"<div><p style='margin:0.2em 0'>{head}</p>"
        "<table><thead><tr><th>parameter</th><th>value</th><th>stderr</th>"
        "<th>95 % interval</th><th>unit</th><th></th></tr></thead>"
        f"<tbody>{''.join(body)}</tbody></table>{foot}</div>"
    )
