#!/usr/bin/env python
"""Install Debian's headless Chromium for the report-rendering test when it is missing.

Called by ``make test``. It never fails the build: where Chromium cannot be installed (no root, no
apt, no network) it says so, and the rendering test skips with that reason.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys

CANDIDATES = ("chromium", "chromium-browser", "google-chrome")


def main() -> int:
    if os.environ.get("PHYSID_NO_CHROMIUM"):
        print(
            "ensure_chromium: PHYSID_NO_CHROMIUM is set; not installing Chromium.", file=sys.stderr
        )
        return 0
    for name in CANDIDATES:
        if shutil.which(name):
            return 0
    if not shutil.which("apt-get") or (hasattr(os, "geteuid") and os.geteuid() != 0):
        print(
            "ensure_chromium: no Chromium and no root apt-get; the HTML rendering test will skip.",
            file=sys.stderr,
        )
        return 0
    print(
        "ensure_chromium: installing Debian's chromium for the report rendering test ...",
        file=sys.stderr,
    )
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    try:
        subprocess.run(
            ["apt-get", "update", "-qq"],
            check=True,
            env=env,
            timeout=600,
            stdout=subprocess.DEVNULL,
        )
        subprocess.run(
            ["apt-get", "install", "-y", "-qq", "--no-install-recommends", "chromium"],
            check=True,
            env=env,
            timeout=900,
            stdout=subprocess.DEVNULL,
        )
    except (subprocess.SubprocessError, OSError) as exc:
        print(
            f"ensure_chromium: could not install chromium ({exc}); the rendering test will skip.",
            file=sys.stderr,
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
