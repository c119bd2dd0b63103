"""Hostile inputs: a model file's [recording] table, an interrupted sweep, a FIFO as the data file.

* an entry of a model file's ``[recording]`` table that does not fit the data file is reported as
  that table's entry (the model file, its line), never as a ``--map`` the user did not pass;
* a ``sweep --out DIR`` interrupted (Ctrl-C) leaves ``DIR`` as it was: nothing partial;
* a data file that is a FIFO (or another non-regular file) is refused before it is opened, so
  physid neither blocks on it nor calls it missing.
"""

from __future__ import annotations

import pytest

from ._cases import case_ids, check_case

_PENDULUM = (
    'name = "pendulum"\ngravity = [0, -9.81, 0]\n[parameters]\n'
    'm1 = { value = 2.0, unit = "kg" }\nl1 = { value = 0.5, unit = "m" }\n'
    '[[joints]]\ndh = { a = "l1" }\nmass = "m1"\n[recording]\n'
)  # the [recording] entry below is on line 10

TABLE_CASES = [
    # (case_id, [recording] entry, message_regex)
    ("table-unit-contradicts-file", 'q1 = "q1 [N]"',
     r"the \[recording\] table of \S*model\.toml \(line 10\) entry q1 = 'q1 \[N\]', but the file "
     r"says 'q1' is in \[rad\]"),
    ("table-unknown-unit", 'q1 = "q1 [furlong]"',
     r"the \[recording\] table of \S*model\.toml \(line 10\) entry q1 = 'q1 \[furlong\]'"),
    ("table-expression-syntax", 'q1 = "2*(q1"',
     r"the \[recording\] table of \S*model\.toml \(line 10\) entry q1: cannot parse"),
    ("table-time-expression", 't = "2*(t"',
     r"the \[recording\] table of \S*model\.toml \(line 10\) entry t: cannot parse"),
]  # fmt: skip


@pytest.mark.parametrize(("case_id", "entry", "message_regex"), TABLE_CASES,
                         ids=case_ids(TABLE_CASES))  # fmt: skip
def test_recording_table_errors_name_the_table(case_id, entry, message_regex, hostile):
    model = hostile.tmp / "model.toml"
    model.write_text(_PENDULUM + entry + "\n", encoding="utf-8")
    result = check_case(hostile, ["identify", "{arm_csv}", "--model", str(model)], 2, message_regex)
    assert "--map" not in result.err.splitlines()[-1].split(". ")[0]
