"""Fuzz the recording loaders (CSV, NPZ, MAT, HDF5): any file either loads into a valid
`Recording` or raises a `PhysidError` — never another exception, never a NaN channel.

``make fuzz`` runs these at 20 000 examples each (profile ``fuzz`` in tests/conftest.py); the
default profile runs a few dozen.
"""

from __future__ import annotations

import tempfile
import warnings
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from physid.errors import PhysidError, PhysidWarning
from physid.signals import Recording, load_recording

_SETTINGS = settings(deadline=None, suppress_health_check=list(HealthCheck))


def _check(path: Path, **kwargs) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a warning escaping the loader is a defect too...
        warnings.simplefilter("ignore", PhysidWarning)  # ...except physid's own notes to the user
        try:
            rec = load_recording(path, **kwargs)
        except PhysidError:
            return
    assert isinstance(rec, Recording)
    assert rec.n_samples >= 2 and np.all(np.diff(rec.t) > 0)
    assert np.all(np.isfinite(rec.data)) and np.all(np.abs(rec.data) <= 1e150)


def _tmp(suffix: str) -> Path:
    return Path(tempfile.mkdtemp(prefix="physid-fuzz-")) / f"f{suffix}"


# ------------------------------------------------------------------------------- CSV
_CELLS = st.sampled_from(
    ["t", "time", "x", "q1", "tau1", "u", "[mm]", "[deg]", "[V]", "[ms]", "[xx]", " [", "]",
     "0", "1", "-2.5", "1e308", "1e999", "nan", "inf", ",", ";", "\t", "\n", "\r\n", '"', "'",
     "#", "# metadata: {\"g\": 2}", "é", "0,5", " "]
)  # fmt: skip
_MAPS = st.one_of(
    st.none(),
    st.dictionaries(
        st.sampled_from(["t", "x", "u", "q1", "tau1"]),
        st.sampled_from(["x", "time", "2*x", "g*u", "x [mm]", "data.pos", "x/0", "(", "t"]),
        max_size=3,
    ),
)


@_SETTINGS
@given(
    text=st.one_of(st.text(max_size=120), st.lists(_CELLS, max_size=80).map("".join)),
    channels=_MAPS,
    decimal=st.sampled_from([".", ","]),
)
def test_csv_loads_or_raises_physid_error(text, channels, decimal):
    path = _tmp(".csv")
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    _check(path, channels=channels, decimal=decimal)


# ------------------------------------------------------------------------------- arrays
_DTYPES = st.sampled_from(["f8", "f4", "i4", "u1", "c16", "U3", "S2", "?", "i8"])


@st.composite
def _array(draw, n):
    dtype = draw(_DTYPES)
    shape = draw(st.sampled_from([(n,), (n, 1), (1, n), (n, 2), (2, n), (), (1,), (n + 1,), (0,)]))
    size = int(np.prod(shape)) if shape else 1
    if dtype.startswith(("U", "S")):
        values = np.array(draw(st.lists(st.text("ab", max_size=2), min_size=size, max_size=size)))
        return values.astype(dtype).reshape(shape)
    raw = draw(
        st.lists(
            st.floats(allow_nan=True, allow_infinity=True, width=64), min_size=size, max_size=size
        )
    )
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return np.array(raw, dtype=float).astype(dtype).reshape(shape)


@st.composite
def _variables(draw):
    n = draw(st.integers(min_value=0, max_value=6))
    names = draw(
        st.lists(
            st.sampled_from(["t", "time", "x", "u", "q1", "tau1", "data", "names", "units", "g"]),
            unique=True,
            max_size=5,
        )
    )
    out = {}
    for name in names:
        if name == "t" and draw(st.booleans()):
            out[name] = 1e-3 * np.arange(n)  # a valid time vector, so that channels are reached
        elif name in ("names", "units"):
            out[name] = np.array(
                draw(st.lists(st.sampled_from(["x", "u", "mm", "V", ""]), max_size=3))
            )
        else:
            out[name] = draw(_array(n))
    return out


@_SETTINGS
@given(
    variables=_variables(), garbage=st.one_of(st.none(), st.binary(max_size=300)), channels=_MAPS
)
def test_npz_loads_or_raises_physid_error(variables, garbage, channels):
    path = _tmp(".npz")
    if garbage is not None:
        path.write_bytes(garbage)
    else:
        np.savez(path, **variables)
    _check(path, channels=channels)


@_SETTINGS
@given(
    variables=_variables(), garbage=st.one_of(st.none(), st.binary(max_size=300)), channels=_MAPS
)
def test_mat_loads_or_raises_physid_error(variables, garbage, channels):
    import scipy.io

    path = _tmp(".mat")
    if garbage is not None:
        path.write_bytes(garbage)
    else:
        clean = {k: v for k, v in variables.items() if v.dtype.kind != "b"}
        try:
            scipy.io.savemat(path, clean)
        except Exception:  # noqa: BLE001 - scipy cannot write some arrays: not the loader's case
            return
    _check(path, channels=channels)


@_SETTINGS
@given(
    variables=_variables(),
    units=st.lists(st.sampled_from(["", "ms", "mm", "deg", "V", "furlong", "min"]), max_size=6),
    garbage=st.one_of(st.none(), st.binary(max_size=300)),
    channels=_MAPS,
)
def test_hdf5_loads_or_raises_physid_error(variables, units, garbage, channels):
    import h5py

    path = _tmp(".h5")
    if garbage is not None:
        path.write_bytes(garbage)
    else:
        with h5py.File(path, "w") as f:
            for (name, value), unit in zip(variables.items(), units + [""] * 10, strict=False):
                if value.dtype.kind == "U":
                    value = value.astype("S")
                target = f.create_group("grp") if name == "g" else f
                ds = target.create_dataset(name if name != "g" else "pos", data=value)
                if unit:
                    ds.attrs["unit"] = unit
    _check(path, channels=channels)
