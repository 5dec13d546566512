"""Gordon 2001, Figs. 7–14, on 3 sin(u cos v): the modified floating horizon
(line drawings), the floating column with intensity (Gouraud, "iis") and
normal (Phong, "nis") interpolation, with and without the §5 corrections,
orthographic and a perspective bird's eye view; plus fcol's default (every
visible pixel solved exactly on its ray).

The seed's artifacts need its coarse sampling: those pictures use
``step=8, max_step=8`` (samples up to 8 pixels apart on the screen), as the
seed's 159 samples per column do; fcol's default keeps samples ≤ 3 pixels
apart, fits a cubic through each pair (heights and exact slopes) and solves
each pixel exactly on its ray from it, so it has none of them."""

from __future__ import annotations

from pathlib import Path

import fcol

EXPR = "3*sin(u*cos(v))"
W, H = 477, 480  # the seed's 480 lines × 477 columns

COARSE = dict(step=8.0, max_step=8.0, refine=False)


def gallery(out_dir: Path) -> list[dict]:
    out_dir = Path(out_dir)
    surf = fcol.Function(EXPR, domain=((-5.0, 5.0), (-5.0, 5.0)))
    wide = fcol.Function(EXPR, domain=((-8.0, 8.0), (-8.0, 8.0)))
    ortho = fcol.View(30, 30, view_height=13.0)
    bird = fcol.View(50, 30, "perspective", distance=30.0, fov=45.0)
    shots = [
        ("floating_fig07_lines.png", surf, ortho, dict(method="floating_horizon", outputs=("lines",), planes=159),
         "Fig. 7: modified floating horizon, 159 planes"),
        ("floating_fig08_iis.png", surf, ortho, dict(shading="intensity", **COARSE),
         "Fig. 8: intensity interpolation, no corrections (triangular patches at ridges)"),
        ("floating_fig09_iis_supersampling.png", surf, ortho,
         dict(shading="intensity", ridges=True, jumps=True, bumps=True, rate=16, **COARSE),
         "Fig. 9: intensity interpolation, local supersampling (rate 16, threshold 0.0625)"),
        ("floating_fig10_nis_spline.png", surf, ortho, dict(shading="normal", ridges=True, correction="spline", **COARSE),
         "Fig. 10: normal interpolation, cubic ridge-top fitting"),
        ("floating_fig11_nis_supersampling.png", surf, ortho,
         dict(shading="normal", ridges=True, rate=16, **COARSE),
         "Fig. 11: normal interpolation, local supersampling"),
        ("floating_fig12_bird_lines.png", wide, bird, dict(method="floating_horizon", outputs=("lines",), planes=200),
         "Fig. 12: perspective bird's eye, line drawing"),
        ("floating_fig13_bird_iis.png", wide, bird, dict(shading="intensity", **COARSE),
         "Fig. 13: bird's eye, intensity interpolation (bump problem at extrema seen from above)"),
        ("floating_fig14_bird_iis_supersampling.png", wide, bird,
         dict(shading="intensity", ridges=True, jumps=True, bumps=True, rate=16, **COARSE),
         "Fig. 14: bird's eye, local supersampling"),
        ("floating_default_ortho.png", surf, ortho, dict(),
         "fcol default: samples ≤ 3 px apart, every pixel exact, Phong"),
        ("floating_default_bird.png", wide, bird, dict(), "fcol default, perspective bird's eye"),
        ("floating_default_ortho_aa4.png", surf, ortho, dict(antialias=4, coverage=True),
         "fcol default, anti-aliased (§6.4): 4 sub-columns × sub-pixel silhouette coverage along the column"),
        ("floating_default_bird_aa4.png", wide, bird, dict(antialias=4),
         "fcol default, perspective, anti-aliased (§6.4): 4 passes on n-rooks sub-pixel rays"),
    ]
    rows = []
    for name, s, view, kw in [(a, b, c, d) for a, b, c, d, _ in shots]:
        note = next(n for a, *_, n in shots if a == name)
        img = fcol.render(s, view, W, H, **kw)
        img.save(out_dir / name)
        rows.append(dict(section="floating", file=name, size=f"{W}x{H}", ms=round(1e3 * img.elapsed, 1),
                         samples=img.samples, note=note))
    return rows
