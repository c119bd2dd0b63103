"""Run a tiny Monte-Carlo sweep of the MSD estimators on a Dask LocalCluster.

Two SNRs × two frequency ratios × two noise realisations, both estimators, 2 s records, on a
LocalCluster of two single-threaded worker processes. On a real cluster, pass
``scheduler="tcp://HOST:8786"`` instead (or ``physid sweep msd --scheduler tcp://HOST:8786``).
The same seed gives the same table with every backend: the script checks it against a serial run.

Run:  python examples/dask_sweep.py [OUT_DIR]
Needs the optional extra: pip install physid[dask]
"""

from __future__ import annotations

import sys
import tempfile

from physid.analysis.msd_study import msd_sweep


def main(out_dir: str) -> None:
    settings = dict(snr_db=[25, 80], ratio=[1, 10], trials=2, duration=2.0, seed=2011)
    result = msd_sweep(**settings, scheduler="local:2")  # starts and stops a LocalCluster
    print(result.message)
    for cell in result.summarize():
        t_hit = cell["t_first_hit"]["median_censored"]
        omega0 = cell["accuracy"]["omega0"]  # bias and spread of the final ω0 over the trials
        print(
            f"{cell['method']:>9}  SNR {cell['snr_db']:>4g} dB  Z = {cell['ratio']:>4g}  "
            f"median time to 2 %: {t_hit if t_hit == t_hit else float('inf'):.3f} s  "
            f"final ω0 error: {cell['final_error']['median']:.2e}  "
            f"bias {omega0['relative_bias']:+.1e}, spread {omega0['relative_spread']:.1e}"
        )
    paths = result.write(out_dir, figures={"convergence_first_hit": result.plot()})
    print("wrote", ", ".join(str(p) for p in paths.values()))
    serial = msd_sweep(**settings, scheduler="serial", progress=False)
    assert serial.to_csv_text() == result.to_csv_text(), "Dask and serial tables differ"
    print("serial run gives the same table bit for bit")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else tempfile.mkdtemp(prefix="physid-sweep-"))
