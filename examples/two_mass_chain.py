"""Two masses on springs: simulate a force test, identify m, c, k of both, print the modes.

The model is examples/models/chain2.toml (m1 = 2 kg, m2 = 1 kg, k1 = 1500, k2 = 3000 N/m,
c1 = 4, c2 = 2 N·s/m; a force on mass 1; both displacements measured). The record is a 20 s
multisine force at 1 kHz (simulated at 10 kHz and sampled, as an anti-aliased acquisition
would), with 40 dB of white noise on both displacements. Then the command line does the same
from the CSV file: ``physid estimate chain.csv --model chain2.toml --modal``.
"""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

import physid
from physid.estimators import make
from physid.signals.excitation import multisine
from physid.signals.recording import Recording
from physid.simulate.structure import simulate_structure

MODEL = Path(__file__).resolve().parent / "models" / "chain2.toml"
QUICK = os.environ.get("PHYSID_EXAMPLE_QUICK") == "1"

model = physid.load_model(MODEL)
truth = model.parameters
print(f"identifiability: {model.identifiability().message}")

rng = np.random.default_rng(1)
duration = 10.0 if QUICK else 20.0
fine = np.arange(0, int(duration * 10_000)) * 1e-4  # 10 kHz, sampled to 1 kHz below
omegas = 2 * np.pi * np.arange(0.25, 25.01, 0.25)
force = 10 * multisine(fine, omegas, 1.0, phases=rng.uniform(0, 2 * np.pi, omegas.size))
clean = simulate_structure(model, fine, {"F": force}).select(["F", "x1", "x2"])[::10]
data = clean.copy()
for j in (1, 2):  # 40 dB: noise power 1e-4 of the signal's
    data[:, j] += rng.standard_normal(len(data)) * np.sqrt(np.mean(clean[:, j] ** 2) * 1e-4)
rec = Recording(fine[::10], data, ["F", "x1", "x2"], ["N", "m", "m"])

result = make("equation-error", model).fit(rec).result_
worst = 0.0
inside = True
for name in result.names:
    value, se = result.parameters[name], result.stderr[name]
    err = 100 * (value - truth[name]) / truth[name]
    worst = max(worst, abs(err))
    inside &= abs(value - truth[name]) <= 1.96 * se
    print(
        f"{name} = {value:.5g} ± {se:.2g} {model.units[name]} (true {truth[name]:g}, error {err:+.2f} %)"
    )
print(f"every parameter within 1 % of the truth: {'yes' if worst < 1 else 'no'}")
print(f"every truth inside its 95 % interval: {'yes' if inside else 'no'}")
print(result.modal().summary())

csv = Path("chain.csv")
rec.save(csv)
cmd = [sys.executable, "-m", "physid", "estimate", str(csv), "--model", str(MODEL), "--modal"]
proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
print(f"physid estimate exit status {proc.returncode}")
print(proc.stdout.strip())
