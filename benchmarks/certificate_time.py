"""Time to build a certificate (``gyro-calib report`` / ``calibrate --report``) per method.

Run (from the repository root, in the project's venv):

    python benchmarks/certificate_time.py [--repeat 3]

For a committed bag of each method the bag is calibrated once, then, ``--repeat`` times (the
best is printed, as the machine is shared): the evidence (the method's figures drawn with
matplotlib and read back, SHA-256 of the bag files), the certificate model with GTC's
k-factors and budgets plus the HTML, and the PDF (WeasyPrint). Figures: seconds of each
step, the HTML and PDF sizes.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

CASES = {
    'rbrlg (K̃, θ: 2 figures)': (['theta_four_position'], None),
    'fog (turntable + self-cal)': (['fog_mapping_self_cal'], None),
    'dither (Z + Y, K given)': (['dither_z', 'dither_y'], None),
    'thermal (model + validation)': (['thermal_calibration'], None),
    'noise (RLG at rest)': (['noise_rlg_static'], ['noise']),
}


def main() -> None:
    """Print the time of each step per method."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--repeat', type=int, default=3)
    args = parser.parse_args()
    from gyro_calib.bag_calibration import calibrate_bags
    from gyro_calib.registry import handoff_schema
    from gyro_calib.report.certificate import build_certificate, render_html, render_pdf
    from gyro_calib.report.evidence import evidence_from_outcome
    from gyro_calib.session import CalibrationOptions

    print(f'load average {os.getloadavg()[0]:.1f}; best of {args.repeat}')
    print(f'{"method":32} {"calibrate":>9} {"evidence":>9} {"model+HTML":>10} {"PDF":>6} '
          f'{"total":>6} {"HTML kB":>8} {"PDF kB":>7}')
    for label, (names, methods) in CASES.items():
        options = CalibrationOptions(
            gyro_id='BENCH', scale_factor_rad_per_pulse=4.0e-6 if 'dither' in label else None)
        t0 = time.perf_counter()
        outcome = calibrate_bags([ROOT / 'bags' / n for n in names], methods=methods,
                                 options=options)
        t_cal = time.perf_counter() - t0
        record = None
        for s in outcome.sessions.values():
            part = s.handoff(outcome.source, gyro_id='BENCH')
            if part is not None:
                record = part if record is None else part.merged_into(record, handoff_schema())
        assert record is not None
        best = [float('inf')] * 3
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            evidence = evidence_from_outcome(outcome, options)
            t1 = time.perf_counter()
            html = render_html(build_certificate(record, evidence))
            t2 = time.perf_counter()
            pdf = render_pdf(html)
            t3 = time.perf_counter()
            best = [min(b, x) for b, x in zip(best, (t1 - t0, t2 - t1, t3 - t2))]
        print(f'{label:32} {t_cal:9.2f} {best[0]:9.2f} {best[1]:10.2f} {best[2]:6.2f} '
              f'{sum(best):6.2f} {len(html) / 1e3:8.0f} {len(pdf) / 1e3:7.0f}', flush=True)


if __name__ == '__main__':
    main()
