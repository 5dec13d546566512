//! `fcol.View`: the camera of SPEC §1.

use crate::camera::{Camera, Projection, View};
use crate::error::FcolError;
use glam::DVec3;
use numpy::ndarray::{Array3, ArrayD, IxDyn};
use numpy::{AllowTypeChange, IntoPyArray, PyArray3, PyArrayDyn, PyArrayLikeDyn};
use pyo3::prelude::*;

/// A camera: elevation α and azimuth β in degrees, orthographic or
/// perspective, looking at `target` (SPEC §1).
///
/// >>> import fcol
/// >>> v = fcol.View(90, 0, view_height=2.0)   # a map: +u right, +v up
/// >>> rows, cols = v.project([[0.5, 0.0, 0.0]], width=4, height=4)
/// >>> float(rows[0]), float(cols[0])
/// (1.5, 2.5)
#[pyclass(name = "View", module = "fcol._fcol", frozen)]
#[derive(Clone)]
pub struct PyView {
    pub view: View,
}

impl PyView {
    pub fn camera(&self, width: usize, height: usize) -> PyResult<Camera> {
        Ok(Camera::new(&self.view, width, height)?)
    }
}

#[pymethods]
impl PyView {
    #[new]
    #[pyo3(signature = (elevation, azimuth, projection = "orthographic", *, target = (0.0, 0.0, 0.0), view_height = None, distance = None, fov = None))]
    fn new(
        elevation: f64,
        azimuth: f64,
        projection: &str,
        target: (f64, f64, f64),
        view_height: Option<f64>,
        distance: Option<f64>,
        fov: Option<f64>,
    ) -> PyResult<Self> {
        let projection = match projection {
            "orthographic" => {
                if distance.is_some() || fov.is_some() {
                    return Err(FcolError::value(
                        "distance",
                        "distance and fov belong to projection=\"perspective\"; an orthographic view takes view_height",
                    )
                    .into());
                }
                Projection::Orthographic {
                    view_height: view_height.ok_or_else(|| {
                        FcolError::value(
                            "view_height",
                            "an orthographic view needs view_height (world units spanning the image height)",
                        )
                    })?,
                }
            }
            "perspective" => {
                if view_height.is_some() {
                    return Err(FcolError::value(
                        "view_height",
                        "view_height belongs to projection=\"orthographic\"; a perspective view takes distance and fov",
                    )
                    .into());
                }
                Projection::Perspective {
                    distance: distance.ok_or_else(|| {
                        FcolError::value(
                            "distance",
                            "a perspective view needs distance (from the target to the eye)",
                        )
                    })?,
                    fov: fov.unwrap_or(40.0),
                }
            }
            other => {
                return Err(FcolError::value(
                    "projection",
                    format!("must be \"orthographic\" or \"perspective\", got {other:?}"),
                )
                .into())
            }
        };
        let view = View {
            elevation,
            azimuth,
            projection,
            target: DVec3::new(target.0, target.1, target.2),
        };
        view.validate()?;
        Ok(PyView { view })
    }

    #[getter]
    fn elevation(&self) -> f64 {
        self.view.elevation
    }
    #[getter]
    fn azimuth(&self) -> f64 {
        self.view.azimuth
    }
    #[getter]
    fn projection(&self) -> &'static str {
        match self.view.projection {
            Projection::Orthographic { .. } => "orthographic",
            Projection::Perspective { .. } => "perspective",
        }
    }
    #[getter]
    fn target(&self) -> (f64, f64, f64) {
        let t = self.view.target;
        (t.x, t.y, t.z)
    }
    #[getter]
    fn view_height(&self) -> Option<f64> {
        match self.view.projection {
            Projection::Orthographic { view_height } => Some(view_height),
            _ => None,
        }
    }
    #[getter]
    fn distance(&self) -> Option<f64> {
        match self.view.projection {
            Projection::Perspective { distance, .. } => Some(distance),
            _ => None,
        }
    }
    #[getter]
    fn fov(&self) -> Option<f64> {
        match self.view.projection {
            Projection::Perspective { fov, .. } => Some(fov),
            _ => None,
        }
    }
    /// The eye position (perspective) or None (orthographic).
    #[getter]
    fn eye(&self) -> Option<(f64, f64, f64)> {
        match self.view.projection {
            Projection::Perspective { distance, .. } => {
                let e = self.view.target - distance * self.view.basis().0;
                Some((e.x, e.y, e.z))
            }
            _ => None,
        }
    }

    /// The unit vectors (d, r, up): view direction, screen right, screen up.
    fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let (d, r, u) = self.view.basis();
        ((d.x, d.y, d.z), (r.x, r.y, r.z), (u.x, u.y, u.z))
    }

    /// Continuous pixel coordinates (rows, cols) of world points (..., 3),
    /// pixel centres at integers; NaN for perspective points at or behind
    /// the near bound.
    fn project<'py>(
        &self,
        py: Python<'py>,
        points: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        width: usize,
        height: usize,
    ) -> PyResult<ArrayPair<'py, PyArrayDyn<f64>>> {
        let (rows, cols, _) = self.project_all(&points, width, height)?;
        Ok((rows.into_pyarray(py), cols.into_pyarray(py)))
    }

    /// Camera depth z of world points (..., 3): (P−T)·d orthographic,
    /// (P−E)·d perspective.
    fn depth<'py>(
        &self,
        py: Python<'py>,
        points: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
        width: usize,
        height: usize,
    ) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
        let (_, _, depth) = self.project_all(&points, width, height)?;
        Ok(depth.into_pyarray(py))
    }

    /// Rays through every pixel centre: (origins, directions), each (H, W, 3)
    /// float64, directions unit length. Orthographic origins lie on the plane
    /// through the target perpendicular to d.
    fn rays<'py>(
        &self,
        py: Python<'py>,
        width: usize,
        height: usize,
    ) -> PyResult<ArrayPair<'py, PyArray3<f64>>> {
        let cam = self.camera(width, height)?;
        let mut o = Vec::with_capacity(3 * width * height);
        let mut d = Vec::with_capacity(3 * width * height);
        for i in 0..height {
            for j in 0..width {
                let (orig, dir) = cam.ray(i as f64, j as f64);
                o.extend_from_slice(&[orig.x, orig.y, orig.z]);
                d.extend_from_slice(&[dir.x, dir.y, dir.z]);
            }
        }
        let o = Array3::from_shape_vec((height, width, 3), o).expect("shape");
        let d = Array3::from_shape_vec((height, width, 3), d).expect("shape");
        Ok((o.into_pyarray(py), d.into_pyarray(py)))
    }

    fn __repr__(&self) -> String {
        let t = self.view.target;
        match self.view.projection {
            Projection::Orthographic { view_height } => format!(
                "View(elevation={}, azimuth={}, projection='orthographic', target=({}, {}, {}), view_height={})",
                self.view.elevation, self.view.azimuth, t.x, t.y, t.z, view_height
            ),
            Projection::Perspective { distance, fov } => format!(
                "View(elevation={}, azimuth={}, projection='perspective', target=({}, {}, {}), distance={}, fov={})",
                self.view.elevation, self.view.azimuth, t.x, t.y, t.z, distance, fov
            ),
        }
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<PyView>()
            .map(|o| o.get().view == self.view)
            .unwrap_or(false)
    }
}

/// A world vector as Python sees it.
type Vec3 = (f64, f64, f64);

/// Two NumPy arrays returned together.
type ArrayPair<'py, A> = (Bound<'py, A>, Bound<'py, A>);

type Triple = (ArrayD<f64>, ArrayD<f64>, ArrayD<f64>);

impl PyView {
    fn project_all(
        &self,
        points: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
        width: usize,
        height: usize,
    ) -> PyResult<Triple> {
        let cam = self.camera(width, height)?;
        let a = points.as_array();
        let shape = a.shape();
        if shape.is_empty() || shape[shape.len() - 1] != 3 {
            return Err(FcolError::value(
                "points",
                format!("must have shape (..., 3), got {shape:?}"),
            )
            .into());
        }
        let out_shape: Vec<usize> = shape[..shape.len() - 1].to_vec();
        let n: usize = out_shape.iter().product();
        let (mut rows, mut cols, mut depth) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        let flat = a
            .to_shape((n, 3))
            .map_err(|e| FcolError::value("points", e.to_string()))?;
        for p in flat.rows() {
            let q = cam.project(DVec3::new(p[0], p[1], p[2]));
            rows.push(q.row);
            cols.push(q.col);
            depth.push(q.depth);
        }
        let mk = |v: Vec<f64>| ArrayD::from_shape_vec(IxDyn(&out_shape), v).expect("shape");
        Ok((mk(rows), mk(cols), mk(depth)))
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyView>()?;
    Ok(())
}
