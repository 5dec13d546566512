"""The gallery: ``python -m fcol.demo --out gallery`` renders every section
(one module of this package each, with a ``gallery(out_dir)`` function that
returns table rows) and prints what it rendered with time and sample counts."""
