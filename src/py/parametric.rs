//! Binding of the parametric scan-line renderer (Blinn 1978).

use super::convert::{buffers_to_dict, parse_outputs, take_shading, Options};
use super::run;
use super::view::PyView;
use crate::error::FcolError;
use crate::parametric::{self, shapes, XScanMode};
use crate::surface::ParametricSurface;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Arc;

type Surf = Arc<dyn ParametricSurface + Send + Sync>;

/// The surface argument: an `fcol.Parametric`, or the name of a built-in
/// shape ("sphere", "torus", "monkey_saddle", "helicoid", "enneper",
/// "bezier").
fn surface_from_py(obj: &Bound<'_, PyAny>) -> PyResult<Surf> {
    if let Ok(s) = super::surfaces::parametric_from_py(obj) {
        return Ok(s);
    }
    if let Ok(name) = obj.extract::<String>() {
        return shapes::by_name(&name).map(Surf::from).ok_or_else(|| {
            FcolError::value(
                "surface",
                format!(
                    "unknown built-in shape {name:?}; choose from \"sphere\", \"torus\", \"monkey_saddle\", \"helicoid\", \"enneper\", \"bezier\""
                ),
            )
            .into()
        });
    }
    Err(FcolError::type_(
        "surface",
        format!(
            "expected fcol.Parametric or a built-in shape name, got {}",
            obj.get_type().name()?
        ),
    )
    .into())
}

fn size(name: &str, n: i64) -> PyResult<usize> {
    if n < 1 {
        return Err(FcolError::value(name, format!("must be at least 1, got {n}")).into());
    }
    Ok(n as usize)
}

/// Render a parametric surface by Blinn's scan line algorithm.
///
/// Options (keywords of `fcol.render`): `x_scan` ("newton": Newton per
/// pixel, exact; "sampled": Blinn's §4 — trackers at equal steps of the
/// normal angle of the scan line's cross-section, carried from scan line to
/// scan line, normals interpolated between them), `samples_per_turn`
/// (sampled: at least this many samples per full turn of the normal,
/// default 16),
/// `max_normal_error` (sampled: degrees, default 0.5; more samples where the
/// interpolated normal would be further off), `grid` (nodes per parameter of
/// the maxima search and the safety net, default 97), `extrapolate`
/// (tracker extrapolation between scan lines, default True),
/// `safety_net` (default True; False stops the traced-curve safety net
/// from adding trackers the tracking missed after a band's first scan
/// line — a check of the tracking alone, not a speed option), and the
/// shading options. `fcol.render` calls it for `fcol.Parametric` surfaces.
///
/// `image.stats` holds the counters of the run: `maxima`, `saddles`,
/// `parabolic_maxima` (§3.4), `created_at_saddles` (§3.2.2.4),
/// `silhouette_y_extrema` (curtain folds and
/// stationary points on the silhouette), `curtain_folds` (§3.4: maxima of
/// y along the silhouette found by the pre-scan) and
/// `created_at_curtain_folds`, `created_at_left_border` (a tracked curve
/// crossed the left image border), `created_at_seams` (a silhouette
/// continued across a closed surface's seam), `newton_per_update` (Newton
/// corrections per tracker update) and `newton_per_update_tenth_px` (those
/// larger than 0.1 px, the seed's stopping rule), `trackers_lost`
/// (non-convergence, §3.2.3), `created_at_maxima` (interior, edge, edge-end
/// and corner maxima), `created_at_folds`, `net_added` (trackers the safety
/// net had to supply: the tracking missed them), `newton_per_pixel`,
/// `fold_walks`, `border_walks`, `convergence_failures` (X-scan
/// continuations that gave up; pixels may be missing there), and for the
/// sampled scan `x_samples` (span ends used), `x_samples_refined` (spans
/// split for the error bound), `turn_points` (§4.3), `x_span_tests`,
/// `x_links_kept` (spans taken from the previous scan line's links),
/// `x_wrong_arc`, `x_sideways` (samples made by the §4.2 sideways
/// iteration), `theta_updates` (normal-angle tracker updates between scan
/// lines), `theta_newton_per_update` with its `_plain` and `_extrapolated`
/// parts (§3.5), `theta_trackers_created`, `theta_trackers_deleted`
/// (unused or merged) and `theta_trackers_lost` (Newton failed, §3.2.3).
///
/// >>> import fcol, math
/// >>> s = fcol.Parametric("cos(v)*cos(u)", "cos(v)*sin(u)", "sin(v)",
/// ...                     domain=((0, 2*math.pi), (-math.pi/2, math.pi/2)))
/// >>> img = fcol.render(s, fcol.View(30, 20, view_height=2.4), 64, 48,
/// ...                   outputs=("mask", "depth"))
/// >>> bool(img.mask[24, 32]), round(float(img.depth[24, 32]), 3), img.stats["convergence_failures"]
/// (True, -0.999, 0.0)
#[pyfunction(name = "render_parametric")]
#[pyo3(signature = (surface, view, width, height, method, outputs, options = None))]
#[allow(clippy::too_many_arguments)]
fn render_parametric_py<'py>(
    py: Python<'py>,
    surface: &Bound<'py, PyAny>,
    view: PyRef<'py, PyView>,
    width: i64,
    height: i64,
    method: &str,
    outputs: &Bound<'py, PyAny>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let surf = surface_from_py(surface)?;
    let (w, h) = (size("width", width)?, size("height", height)?);
    if method != "scanline" {
        return Err(FcolError::value(
            "method",
            format!("parametric surfaces are drawn with method=\"scanline\", got {method:?}"),
        )
        .into());
    }
    let outputs = parse_outputs(outputs)?;
    if outputs.lines {
        return Err(FcolError::value(
            "outputs",
            "\"lines\" is drawn by the floating horizon of function surfaces; the scan line renderer gives rgb, intensity, depth, normal, uv, side, mask",
        )
        .into());
    }
    let o = Options::new(options, py)?;
    let shading = take_shading(&o)?;
    let mut opts = parametric::Options::default();
    let x_scan = o.take::<String>("x_scan")?;
    let per_turn = o.take::<i64>("samples_per_turn")?;
    let max_error = o.take::<f64>("max_normal_error")?;
    opts.x_scan = match x_scan.as_deref() {
        None | Some("newton") => {
            if per_turn.is_some() || max_error.is_some() {
                return Err(FcolError::value(
                    "samples_per_turn",
                    "samples_per_turn and max_normal_error belong to x_scan=\"sampled\"",
                )
                .into());
            }
            XScanMode::Newton
        }
        Some("sampled") => XScanMode::Sampled {
            per_turn: match per_turn {
                None => 16,
                Some(n) if (4..=4096).contains(&n) => n as usize,
                Some(n) => {
                    return Err(FcolError::value(
                        "samples_per_turn",
                        format!("must be in 4..=4096, got {n}"),
                    )
                    .into())
                }
            },
            max_error: max_error.unwrap_or(0.5),
        },
        Some(other) => {
            return Err(FcolError::value(
                "x_scan",
                format!("expected \"newton\" or \"sampled\", got {other:?}"),
            )
            .into())
        }
    };
    if let Some(g) = o.take::<i64>("grid")? {
        if !(5..=2049).contains(&g) {
            return Err(FcolError::value("grid", format!("must be in 5..=2049, got {g}")).into());
        }
        opts.grid = g as usize;
    }
    if let Some(e) = o.take::<bool>("extrapolate")? {
        opts.extrapolate = e;
    }
    if let Some(e) = o.take::<bool>("safety_net")? {
        opts.safety_net = e;
    }
    o.finish("render(method=\"scanline\")")?;
    let v = view.view;
    let t0 = std::time::Instant::now();
    let abort = || super::surfaces::abort_callables(surface);
    let b = run::cancellable_aborting(py, abort, |cancel| {
        parametric::render(surf.as_ref(), &v, w, h, &outputs, &shading, &opts, cancel)
    });
    // An exception raised by a Python callable behind the surface wins.
    super::surfaces::check_surface_errors(surface)?;
    let b = b?;
    buffers_to_dict(py, b, t0.elapsed().as_secs_f64())
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(render_parametric_py, m)?)?;
    Ok(())
}
