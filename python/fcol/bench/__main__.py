"""Run the benchmarks and print one table per section."""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
from pathlib import Path

import fcol
import fcol.bench


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m fcol.bench", description=__doc__)
    ap.add_argument("sections", nargs="*", help="only these sections (default: all)")
    ap.add_argument("--out", default="bench-out", help="folder for plots and tables")
    ap.add_argument("--quick", action="store_true", help="fewer sizes and repeats")
    args = ap.parse_args(argv)
    if fcol.build_profile != "release":
        print("warning: fcol is a debug build; timings are meaningless (make build)", file=sys.stderr)
    print(f"fcol {fcol.__version__}, {fcol.build_profile} build for {fcol.build_features or 'the baseline'}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    names = sorted(m.name for m in pkgutil.iter_modules(fcol.bench.__path__) if not m.name.startswith("_"))
    if args.sections:
        unknown = set(args.sections) - set(names)
        if unknown:
            ap.error(f"unknown sections {sorted(unknown)}; choose from {names}")
        names = [n for n in names if n in args.sections]
    with fcol.bench.quiet_blas() as blas:
        print(blas)
        for name in names:
            _section(name, out, args.quick)
    return 0


def _section(name: str, out: Path, quick: bool) -> None:
    mod = importlib.import_module(f"fcol.bench.{name}")
    rows = mod.run(out, quick)
    if rows:
        cols = list(dict.fromkeys(k for r in rows for k in r))
        fmt = lambda v: f"{v:.4g}" if isinstance(v, float) else str(v)  # noqa: E731
        widths = {c: max(len(c), *(len(fmt(r.get(c, ""))) for r in rows)) for c in cols}
        lines = ["  ".join(c.ljust(widths[c]) for c in cols), "  ".join("-" * widths[c] for c in cols)]
        lines += ["  ".join(fmt(r.get(c, "")).ljust(widths[c]) for c in cols) for r in rows]
        print(f"\n== {name} ==")
        print("\n".join(lines))
        # the same table in the output folder, beside the section's plots
        (out / f"{name}.txt").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    sys.exit(main())
