"""Render the gallery and print a table of what was rendered."""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
from pathlib import Path

import fcol.demo
from fcol.bench import quiet_blas


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m fcol.demo", description=__doc__)
    ap.add_argument("--out", default="gallery", help="folder for the pictures (default: gallery)")
    ap.add_argument("sections", nargs="*", help="only these sections (default: all)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    names = sorted(m.name for m in pkgutil.iter_modules(fcol.demo.__path__) if not m.name.startswith("_"))
    if args.sections:
        unknown = set(args.sections) - set(names)
        if unknown:
            ap.error(f"unknown sections {sorted(unknown)}; choose from {names}")
        names = [n for n in names if n in args.sections]
    rows: list[dict[str, object]] = []
    # (the timings printed as the bench takes them, see fcol.bench.quiet_blas)
    with quiet_blas():
        for name in names:
            mod = importlib.import_module(f"fcol.demo.{name}")
            rows.extend(mod.gallery(out))
    cols = ["section", "file", "size", "ms", "samples", "note"]
    widths = {c: max(len(c), *(len(str(r.get(c, ""))) for r in rows)) if rows else len(c) for c in cols}
    print("  ".join(c.ljust(widths[c]) for c in cols))
    print("  ".join("-" * widths[c] for c in cols))
    for r in rows:
        print("  ".join(str(r.get(c, "")).ljust(widths[c]) for c in cols))
    print(f"\n{len(rows)} pictures in {out}/ (fcol {fcol.__version__}, {fcol.build_profile} build)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
