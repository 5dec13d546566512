"""Independent references for checking fcol's pictures.

Nothing here uses fcol's renderers: ``spec_camera`` is SPEC §1 written in
NumPy from the contract's text; the reference ray casters use trimesh +
embreex and refine each hit on the exact surface. Tests and benchmarks use
them, and so can anyone who wants to measure a render's error. ``sky``
holds the whole-array NumPy formulation of a horizon map's sky light and
sun shadows, against which the per-point Rust versions are checked."""
