"""Gallery section ``parametric``: the test surfaces drawn by Blinn's scan
line, with the exact (Newton per pixel) and the sampled (normal-angle
samples, Phong interpolation) X scans side by side."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

import fcol
from fcol.image import png_bytes

PI = np.pi

SCENES = [
    ("sphere", ("cos(v)*cos(u)", "cos(v)*sin(u)", "sin(v)"), ((0, 2 * PI), (-PI / 2, PI / 2)),
     fcol.View(35, 25, view_height=2.4), "poles in view"),
    ("torus", ("(1 + 0.4*cos(v))*cos(u)", "(1 + 0.4*cos(v))*sin(u)", "0.4*sin(v)"), ((0, 2 * PI), (0, 2 * PI)),
     fcol.View(40, 30, "perspective", distance=4.5, fov=45), "saddles and inner silhouettes"),
    ("monkey_saddle", ("u", "v", "u**3 - 3*u*v**2"), ((-1, 1), (-1, 1)),
     fcol.View(30, 30, view_height=4.6), "monkey saddle"),
    ("helicoid", ("v*cos(u)", "v*sin(u)", "0.15*u"), ((0, 3 * PI), (-1, 1)),
     fcol.View(25, 40, view_height=3.4), "helicoid, 1.5 turns"),
    ("enneper", ("u - u**3/3 + u*v**2", "v - v**3/3 + v*u**2", "u**2 - v**2"), ((-2, 2), (-2, 2)),
     fcol.View(40, 30, view_height=15), "Enneper's surface, self-intersecting"),
    ("bezier", ("3*u - 1.5", "3*v - 1.5",
                "3*u*(1-u)**2*(0.5*(1-v)**3 + 4.8*v*(1-v)**2 - 3.6*v*v*(1-v)) + "
                "3*u*u*(1-u)*(-0.3*(1-v)**3 - 3*v*(1-v)**2 + 5.4*v*v*(1-v) + 0.6*v**3) + "
                "(1-u)**3*(1.8*v*(1-v)**2 - 1.2*v*v*(1-v) + 0.2*v**3) + "
                "u**3*(0.1*(1-v)**3 + 1.2*v*(1-v)**2 + 0.6*v*v*(1-v) - 0.5*v**3)"),
     ((0, 1), (0, 1)), fcol.View(35, 60, "perspective", distance=5.5, fov=45), "bicubic Bézier height patch"),
]


def gallery(out_dir: Path) -> list[dict[str, Any]]:
    out_dir = Path(out_dir)
    rows: list[dict[str, Any]] = []
    size = 400
    for name, (x, y, z), dom, view, note in SCENES:
        surf = fcol.Parametric(x, y, z, domain=dom)
        for x_scan in ("newton", "sampled"):
            t0 = time.perf_counter()
            img = fcol.render(surf, view, size, size, outputs=("rgb",), x_scan=x_scan,
                              specular=0.25, shininess=40.0)
            dt = time.perf_counter() - t0
            file = f"parametric_{name}_{x_scan}.png"
            (out_dir / file).write_bytes(png_bytes(img.rgb))
            s = img.stats
            extra = (f"{s['newton_per_update']:.2f} Newton/update, {s['newton_per_pixel']:.2f} per pixel"
                     if x_scan == "newton" else
                     f"{int(s['x_samples'])} normal-angle samples, {int(s['theta_updates'])} tracker updates at "
                     f"{s['theta_newton_per_update']:.2f} Newton each")
            rows.append({"section": "parametric", "file": file, "size": f"{size}x{size}", "ms": round(dt * 1e3, 1),
                         "samples": img.samples,
                         "note": f"{note}; {x_scan} X scan; {extra}; {int(s['convergence_failures'])} failures"})
    return rows
