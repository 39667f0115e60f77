"""Screenshots of the inspection report for docs/report.md: a clean, an altered and an
inconclusive bat, rendered in headless Chromium.

    python benchmarks/report_gallery.py [-o DIR] [--img docs/img] [--plots DIR]

The built-in bat (``batlab demo``'s virtual rig) is registered, then re-tested weeks later
(moisture +0.8 points, accelerometer re-mounted): once unaltered, once corked (1 in core,
10 in deep, fill 0.3). Both are inspected through the registry and reported by the real
pipeline. The inconclusive page renders the clean inspection's stored evidence with the
three-way verdict form (``status`` "inconclusive", ``altered`` null, ``reasons``) that the
inspection emits when two tests cannot be compared; its reason is an example. Writes
``report_{clean,altered,inconclusive}.png`` (the top of each page, 1100 px wide); with
``--plots DIR`` also each page's figures as PNG (``DIR/{clean,altered,inconclusive}/``), to
check them by eye.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from batlab import pipeline  # noqa: E402
from batlab.pipeline import DEMO_RETEST, simulate_demo_pair  # noqa: E402
from batlab.registry import open_registry  # noqa: E402
from batlab.report import write_plots, write_report  # noqa: E402

INCONCLUSIVE_REASON = ("the re-test's amplitudes are about 1000 times the baseline's, as a "
                       "units or sensitivity slip makes them: check the accelerometer's "
                       "calibration and test again")


def screenshot(page: Path, png: Path, height: int = 1500) -> None:
    subprocess.run(["chromium", "--headless", "--no-sandbox", "--disable-gpu",
                    "--hide-scrollbars", f"--screenshot={png}", f"--window-size=1100,{height}",
                    page.resolve().as_uri()], check=True, capture_output=True, timeout=120)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--out", default=None, help="work directory (default: temporary)")
    ap.add_argument("--img", default="docs/img", help="where the screenshots go")
    ap.add_argument("--plots", default=None, metavar="DIR",
                    help="also write each page's figures as PNG into DIR/<case>/")
    args = ap.parse_args()
    if shutil.which("chromium") is None:
        print("chromium not installed (apt-get install chromium)", file=sys.stderr)
        return 2
    work = Path(args.out or tempfile.mkdtemp(prefix="batlab-gallery-"))
    img = Path(args.img)
    img.mkdir(parents=True, exist_ok=True)

    def progress(msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    pages = {}
    with open_registry(work / "registry.sqlite") as conn:
        for case, alteration in (("clean", None), ("altered", DEMO_RETEST["alteration"])):
            folder = work / case
            folder.mkdir(parents=True, exist_ok=True)
            files = simulate_demo_pair(folder, 7, progress, alteration)
            profile, meta, baseline, retest = files.profile, files.meta, files.baseline, \
                files.retest
            done = pipeline.register_files(conn, profile, meta, baseline, replace=True,
                                           progress=progress)
            result = pipeline.inspect_registered(conn, done.record.serial, retest,
                                                 refit_baseline=True, progress=progress,
                                                 baseline_fit=done.baseline.fit)
            stored = pipeline.store_inspection(conn, result, retest)
            inputs = pipeline.report_inputs(result, done.record.meta,
                                            pipeline.provenance(conn, stored=stored))
            shown = {case: inputs}
            if case == "clean":
                verdict = {**inputs.verdict, "status": "inconclusive", "altered": None,
                           "reasons": [INCONCLUSIVE_REASON]}
                shown["inconclusive"] = replace(inputs, verdict=verdict)
            for name, page_inputs in shown.items():
                pages[name] = write_report(work / name / "report", page_inputs)
                if args.plots:
                    write_plots(Path(args.plots) / name, page_inputs)
    for case, page in pages.items():
        png = img / f"report_{case}.png"
        screenshot(page, png)
        print(f"{case}: {page} -> {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
