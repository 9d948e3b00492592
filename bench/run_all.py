"""Run every benchmark script in bench/ in turn (`make bench`).

Each script prints its own tables: ratios against peers measured in the same process on the
same files. Pass names to run a subset: `python bench/run_all.py io filters`.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ORDER = [
    "footlock",
    "io",
    "motive",
    "formats",
    "scale",
    "filters",
    "bilateral",
    "despike",
    "fairing",
    "multires",
    "resample",
    "gaps",
    "world",
    "batch",
    "quality",
    "realnoise",
]


def main() -> int:
    wanted = sys.argv[1:] or [name for name in ORDER if (HERE / f"{name}.py").exists()]
    failed = []
    for name in wanted:
        print(f"\n=== bench/{name}.py ===", flush=True)
        start = time.perf_counter()
        code = subprocess.call([sys.executable, str(HERE / f"{name}.py")])
        print(f"--- {name}: {time.perf_counter() - start:.1f} s, exit {code}", flush=True)
        if code:
            failed.append(name)
    if failed:
        print(f"failed: {', '.join(failed)}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
