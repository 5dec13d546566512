//! `render_height`: the native entry of `fcol.render` for function surfaces
//! w = f(u, v) (floating column and floating horizon).

use super::convert::{buffers_to_dict, parse_outputs, take_shading, Options};
use super::run;
use super::surfaces::PyHeightGrid;
use super::view::PyView;
use crate::error::FcolError;
use crate::floating::{self, Corrections, FloatingOptions, ShadingMode};
use crate::image::Buffers;
use crate::surface::HeightField;
use crate::texture::Texture;
use numpy::{PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::time::Instant;

fn parse_options(o: &Options<'_>, method: &str) -> PyResult<FloatingOptions> {
    let mut f = FloatingOptions::default();
    if let Some(s) = o.take::<String>("shading")? {
        f.shading = match s.as_str() {
            "normal" => ShadingMode::Normal,
            "intensity" => ShadingMode::Intensity,
            other => {
                return Err(FcolError::value(
                    "shading",
                    format!("must be \"normal\" (Phong) or \"intensity\" (Gouraud), got {other:?}"),
                )
                .into())
            }
        };
    }
    if let Some(v) = o.take("refine")? {
        f.refine = v;
    }
    if let Some(v) = o.take("step")? {
        f.step = Some(v);
    }
    if let Some(v) = o.take("max_step")? {
        f.max_step = Some(v);
    }
    if let Some(v) = o.take("refine_tol")? {
        f.refine_tol = v;
    }
    if let Some(v) = o.take("refine_iters")? {
        f.refine_iters = v;
    }
    let mut c = Corrections::default();
    if let Some(v) = o.take("ridges")? {
        c.ridges = v;
    }
    if let Some(v) = o.take("jumps")? {
        c.jumps = v;
    }
    if let Some(v) = o.take("bumps")? {
        c.bumps = v;
    }
    if let Some(v) = o.take("walls")? {
        c.walls = v;
    }
    if let Some(s) = o.take::<String>("correction")? {
        c.spline = match s.as_str() {
            "spline" => true,
            "supersample" => false,
            other => {
                return Err(FcolError::value(
                    "correction",
                    format!("must be \"supersample\" or \"spline\", got {other:?}"),
                )
                .into())
            }
        };
    }
    if let Some(v) = o.take("rate")? {
        c.rate = v;
    }
    if let Some(v) = o.take("threshold")? {
        c.threshold = v;
    }
    f.corrections = c;
    if let Some(v) = o.take("antialias")? {
        f.antialias = v;
    }
    if let Some(v) = o.take("coverage")? {
        f.coverage = v;
    }
    if method == "floating_horizon" {
        if let Some(v) = o.take("planes")? {
            f.planes = v;
        }
    }
    if let Some(v) = o.take("threads")? {
        f.threads = Some(v);
    }
    if let Some(v) = o.take("height_bound")? {
        f.height_bound = v;
    }
    if let Some(v) = o.take("bin_width")? {
        f.bin_width = Some(v);
    }
    Ok(f)
}

/// Render a function surface (called by `fcol.render`): `method` is
/// "floating_column" (shaded, Gordon 2001 §4.2) or "floating_horizon" (line
/// drawing, §4.1; buffers "lines" and "mask"). Returns the keyword arguments
/// of `fcol.Image`. Options (unknown ones are a TypeError):
///
/// * `shading`: "normal" (Phong, default) or "intensity" (Gouraud);
/// * `refine` (True): solve each visible pixel exactly on its ray, seeded
///   by the cubic through its span's two samples (heights and exact
///   slopes): depth and normal errors are those of the solve (measured:
///   depth ≤ 1e-4 px median, ≤ 1e-3 px p99; normal ≤ 1e-3° median,
///   ≤ 0.05° p99), about one evaluation per visible pixel. `refine=False`
///   takes the cubic's point instead (in perspective moved onto the
///   pixel's own ray through the tangent plane there) and interpolates
///   normals; only pixels whose span folds over or whose ray grazes are
///   solved: depth stays within 0.02 px median, 0.5 px p99, normals
///   carry the interpolation error (0.2° median on smooth surfaces, up to
///   a few degrees on a grid's kinks); it saves about 10 % of the time
///   (orthographic; little in perspective). After the sweeps, in both
///   projections, unset pixels beside set ones (the mask's edge) and set
///   pixels beside a nearer neighbour (a crest in front the samples
///   stepped over) are searched on their own rays from their neighbours'
///   hits; an orthographic pixel whose exact solve finds no crossing is
///   left for that search rather than interpolated (not with `antialias`
///   shading, whose sub-columns shade the silhouettes);
/// * `step` (1.0 with `coverage`; else 5.0 where pixels are solved
///   exactly, `refine=True`, 8.0 in perspective, each step there also
///   held within 0.05 pixel of its chord, 0.2 in perspective; 3.0
///   without): largest screen gap between samples, pixels; `max_step`
///   (4.0; 2.0 with `coverage`): largest step along a sweep, in pixel
///   footprints (step=1, max_step=2: the dense sweep, 1.5–2× the
///   samples);
/// * `ridges`, `bumps`, `jumps` (False): §5 detections between two
///   samples (V·N changes sign, the normal swings past the view in the
///   sweep's plane, the intensity steps by more than `threshold`, 0.0625);
///   `correction`: "supersample" (the span split into `rate` (8) parts) or
///   "spline" (one at the extremum of the cubic through them: the crest's
///   top, the bump's brightest point); `walls` (True): shade steps as
///   walls (§5.1). With the seed's sampling (`step=8, max_step=8,
///   refine=False`), supersampling lowers the shading error on the pixels
///   it changes by 2–500× (intensity shading; jumps and bumps under normal
///   shading 1.8–300×), and either correction restores an orthographic
///   crest cut off between samples (worst depth error 3.5 → 0.08 px);
///   the spline lowers a bump's error by a fifth to two fifths, but with
///   `shading="intensity"` its ridge-top sample, dark at the silhouette,
///   spreads over the span (14–17 % more error on the pixels it changes):
///   there, supersample (the bench's correction rows give the figures);
/// * `antialias` (1): column supersampling of rgb/intensity (§6.4): k
///   sub-columns per pixel column, averaged (perspective views: k passes
///   of the radial sweep at sub-column offsets);
/// * `coverage` (False): sub-pixel coverage of rgb/intensity in the
///   column direction (perspective views: along each sweep's vertical
///   plane) (§6.4): a pixel crossed by a
///   silhouette (a span's outer end against the background, the domain
///   edge or a hole, at floating-point rows, with the extremum between
///   samples) is blended with the background by the covered fraction of
///   its row extent; intensity is the surface's times that fraction (NaN
///   where nothing is covered). depth/normal/uv/side/mask stay per pixel
///   centre. With `antialias` it gives both directions;
/// * `planes` (80, floating_horizon): number of sampling planes;
/// * `threads`: worker threads (default: all); output is identical for any;
/// * `height_bound` (True): in perspective, stop each vertical plane's
///   sweep once the surface's height bound (an expression's interval bound
///   over the domain, a grid's block maxima along the plane; none for
///   callables) shows that no
///   point further on can rise into an elevation of the plane's pixels
///   that is not already covered — a landscape seen from a low eye stops
///   at the first ridge that hides the rest. The picture is identical
///   either way (`False` sweeps every plane to the domain's end). (Apart
///   from this option, a stretch of a column or plane that the surface's
///   bounds over it keep wholly below or above the picture is always
///   stepped over at once: a zoomed view does not sweep the whole domain
///   at its tiny pixel's steps);
/// * `bin_width` (perspective; 1.25 with `refine`, else 1.0, and 1.0 with
///   `coverage`): the widest azimuth bin, in pixels across at the most
///   sensitive pixel — each bin sweeps one vertical plane through the eye
///   and its pixels lie up to half of this off it (their exact solve and
///   the search along the mask's edge absorb that offset); in (0, 4];
/// * `texture` (floating_column): an (H, W) array over the surface's
///   domain, laid out like a height grid's z, multiplying each pixel's
///   intensity and rgb at the pixel's (u, v) (see [`texture_from_py`]);
/// * the shading options of every renderer (`light`, `ambient`, ...).
///
/// >>> import fcol
/// >>> s = fcol.Function("exp(-(u*u + v*v))", domain=((-2, 2), (-2, 2)))
/// >>> img = fcol.render(s, fcol.View(40, 20, view_height=5.0), 64, 48, outputs=("rgb", "depth"))
/// >>> img.depth.shape, bool(img.samples > 0)
/// ((48, 64), True)
#[pyfunction]
#[pyo3(signature = (surface, view, width, height, method, outputs, options = None))]
#[allow(clippy::too_many_arguments)]
fn render_height<'py>(
    py: Python<'py>,
    surface: &Bound<'py, PyAny>,
    view: &Bound<'py, PyAny>,
    width: usize,
    height: usize,
    method: &str,
    outputs: &Bound<'py, PyAny>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyDict>> {
    let view = view
        .cast::<PyView>()
        .map_err(|_| pyo3::exceptions::PyTypeError::new_err("view: expected fcol.View"))?
        .get()
        .view;
    let horizon = match method {
        "floating_column" => false,
        "floating_horizon" => true,
        other => {
            return Err(FcolError::value(
                "method",
                format!(
                "function surfaces take \"floating_column\" or \"floating_horizon\", got {other:?}"
            ),
            )
            .into())
        }
    };
    let mut outputs = parse_outputs(outputs)?;
    let o = Options::new(options, py)?;
    let texture = match o.take::<Bound<'py, PyAny>>("texture")? {
        Some(_) if horizon => {
            return Err(FcolError::value(
                "texture",
                "applies to method=\"floating_column\" (shaded pixels)",
            )
            .into());
        }
        Some(t) => Some(texture_from_py(py, &t, surface)?),
        None => None,
    };
    // The texture is looked up at each pixel's (u, v): ask the renderer for
    // them, and drop them again if the caller did not.
    let keep_uv = outputs.uv;
    if texture.is_some() {
        outputs.uv = true;
    }
    let shading = take_shading(&o)?;
    let fopts = parse_options(&o, method)?;
    o.finish(&format!("fcol.render(method={method:?})"))?;
    fopts.validate()?;
    crate::error::check_size(width, height)?;
    let field = super::surfaces::height_field_from_py(surface)?;
    let t0 = Instant::now();
    let abort = || super::surfaces::abort_callables(surface);
    let buf = run::cancellable_aborting(py, abort, |cancel| {
        let f: &dyn HeightField = &*field;
        if horizon {
            floating::render_floating_horizon(
                f, &view, width, height, &outputs, &shading, &fopts, cancel,
            )
        } else {
            let mut b = floating::render_floating_column(
                f, &view, width, height, &outputs, &shading, &fopts, cancel,
            )?;
            if let Some(t) = &texture {
                apply_texture(t, &mut b, keep_uv, cancel)?;
            }
            Ok(b)
        }
    });
    let elapsed = t0.elapsed().as_secs_f64();
    // An exception raised by a Python callable behind the surface wins; it
    // is taken (and the callable reset) whether or not the core failed.
    super::surfaces::check_surface_errors(surface)?;
    buffers_to_dict(py, buf?, elapsed)
}

/// `texture=`: any real 2-D array, placed over the surface like a height
/// grid's z — over a `fcol.HeightGrid`'s extent (v0 > v1 when north-up),
/// else over the domain ((u0, u1), (v0, v1)). Non-finite texels count as 0.
fn texture_from_py(
    py: Python<'_>,
    obj: &Bound<'_, PyAny>,
    surface: &Bound<'_, PyAny>,
) -> PyResult<Texture> {
    let np = py.import("numpy")?;
    let a = np.call_method1("asarray", (obj,)).map_err(|e| {
        pyo3::exceptions::PyTypeError::new_err(format!(
            "texture: expected a 2-D array of real numbers ({})",
            e.value(py)
        ))
    })?;
    let kind: String = a.getattr("dtype")?.getattr("kind")?.extract()?;
    if !matches!(kind.as_str(), "b" | "i" | "u" | "f") {
        let dt = a.getattr("dtype")?.str()?.to_string();
        return Err(pyo3::exceptions::PyTypeError::new_err(format!(
            "texture: expected real values (an integer or float dtype), got dtype {dt}"
        )));
    }
    let ndim: usize = a.getattr("ndim")?.extract()?;
    if ndim != 2 {
        let shape = a.getattr("shape")?.repr()?.to_string();
        return Err(FcolError::value(
            "texture",
            format!("must be a 2-D array (rows along v, columns along u), got shape {shape}"),
        )
        .into());
    }
    let a = a.call_method1("astype", ("float64",))?;
    let arr: PyReadonlyArray2<'_, f64> = a.extract()?;
    let (rows, cols) = (arr.shape()[0], arr.shape()[1]);
    let texels: Vec<f64> = arr.as_array().iter().copied().collect();
    let place = if surface.cast::<PyHeightGrid>().is_ok() {
        surface
            .getattr("extent")?
            .extract::<(f64, f64, f64, f64)>()?
    } else {
        let ((u0, u1), (v0, v1)) = surface.getattr("domain")?.extract()?;
        (u0, u1, v0, v1)
    };
    Ok(Texture::new(texels, rows, cols, place)?)
}

/// Multiply the shaded buffers by the texture; drop the (u, v) buffer if
/// only the texture needed it.
fn apply_texture(
    t: &Texture,
    b: &mut Buffers,
    keep_uv: bool,
    cancel: &crate::cancel::Cancel,
) -> crate::error::Result<()> {
    let Some(uv) = b.uv.as_deref() else {
        return Ok(());
    };
    t.apply(
        b.width,
        uv,
        b.intensity.as_deref_mut(),
        b.rgb.as_deref_mut(),
        cancel,
    )?;
    if !keep_uv {
        b.uv = None;
    }
    Ok(())
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(render_height, m)?)?;
    Ok(())
}
