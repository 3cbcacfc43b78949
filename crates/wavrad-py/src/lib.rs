//! Python bindings of wavrad: `wavrad._native`, re-exported by the `wavrad`
//! package (`python/wavrad`).
//!
//! This crate only converts and calls: Python arguments become core settings
//! and enums, numpy arrays become pixel buffers and back, and errors become
//! the exception tree of [`error`]. Every computation lives in `wavrad-core`
//! and every file format in `wavrad-io`.

mod error;

use std::path::PathBuf;

use glam::DVec3;
use numpy::ndarray::Array3;
use numpy::{
    AllowTypeChange, IntoPyArray, PyArray3, PyArrayLike1, PyArrayLike3, PyArrayLikeDyn,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::ops::ControlFlow;
use wavrad_core::progress::Silent;
use wavrad_core::render::{RenderSettings, Renderer};
use wavrad_core::setting::{Described, Domain, Value};
use wavrad_core::solve::shoot::{solve_shooting, Step};
use wavrad_core::solve::{SolveSettings, Solver};

use error::{Error, Result, SceneError, SolveError, WavradError};

/// A scene loaded from a Mitsuba 3 XML file.
#[pyclass(module = "wavrad", frozen)]
struct Scene(wavrad_core::scene::Scene);

#[pymethods]
impl Scene {
    /// Number of surfaces (two-sided materials count twice).
    #[getter]
    fn surface_count(&self) -> usize {
        self.0.surfaces.len()
    }

    /// Film width in pixels.
    #[getter]
    fn width(&self) -> u32 {
        self.0.film.width
    }

    /// Film height in pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.0.film.height
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene(surfaces={}, film={}x{})",
            self.0.surfaces.len(),
            self.0.film.width,
            self.0.film.height
        )
    }
}

/// A view-independent radiance solution, with the renderer of its views.
#[pyclass(module = "wavrad", frozen)]
struct Solution(Renderer);

#[pymethods]
impl Solution {
    /// Render the scene's sensor, or another view of the solution (moved by
    /// Mitsuba's look_at `origin`/`target`/`up`, `fov` in degrees along the
    /// scene's `fov_axis`); returns an (height, width, 3) float32 array of
    /// linear RGB radiance. The render settings (`mode`, `spp`, and by
    /// keyword `gather_spp`, `eye`, `gather_cache`) are those of
    /// [`RenderSettings::SETTINGS`].
    #[pyo3(signature = (mode=None, spp=None, *, origin=None, target=None, up=None, fov=None, **settings))]
    #[allow(clippy::too_many_arguments)] // keyword arguments of the Python API
    fn render<'py>(
        &self,
        py: Python<'py>,
        mode: Option<&str>,
        spp: Option<u32>,
        origin: Option<PyArrayLike1<'py, f64, AllowTypeChange>>,
        target: Option<PyArrayLike1<'py, f64, AllowTypeChange>>,
        up: Option<PyArrayLike1<'py, f64, AllowTypeChange>>,
        fov: Option<f64>,
        settings: Option<&Bound<'py, PyDict>>,
    ) -> Result<Bound<'py, PyArray3<f32>>> {
        let scene = &self.0.solution().scene;
        let positional = PyDict::new(py);
        if let Some(mode) = mode {
            positional.set_item("mode", mode)?;
        }
        if let Some(spp) = spp {
            positional.set_item("spp", spp)?;
        }
        if let Some(settings) = settings {
            positional.update(settings.as_mapping())?;
        }
        let given = described_values::<RenderSettings>(Some(&positional))?;
        let settings = RenderSettings::from_values(scene, &given)?;
        let mut camera = scene.camera.ok_or(wavrad_core::Error::NoSensor)?;
        let (origin, target, up) = (
            vector("origin", origin)?,
            vector("target", target)?,
            vector("up", up)?,
        );
        if origin.is_some() || target.is_some() || up.is_some() {
            camera = camera.with_look_at(origin, target, up).ok_or_else(|| {
                Error::Argument(
                    "render: degenerate look_at (origin equals target, or up is zero or \
                     parallel to the view direction)"
                        .into(),
                )
            })?;
        }
        if let Some(fov) = fov {
            let aspect = f64::from(scene.film.width) / f64::from(scene.film.height);
            camera = camera.with_fov(fov, aspect).ok_or_else(|| {
                Error::Argument(if fov > 0.0 && fov < 180.0 {
                    "render: fov needs a perspective sensor, the scene's is orthographic".into()
                } else {
                    format!("render: fov = {fov} is outside (0, 180) degrees")
                })
            })?;
        }
        let image = py.allow_threads(|| self.0.render_view(&camera, &scene.film, &settings))?;
        Ok(pixels(py, image.width, image.height, image.rgb))
    }

    /// Statistics of the solve (the paper's §5 quantities, times, memory).
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> Result<Bound<'py, PyAny>> {
        let json =
            serde_json::to_string(&self.0.solution().stats).expect("Stats serialise to JSON");
        Ok(py.import("json")?.call_method1("loads", (json,))?)
    }

    fn __repr__(&self) -> String {
        let s = &self.0.solution().stats;
        format!(
            "Solution(two_point_nodes={}, two_point_interactions={}, iterations={})",
            s.two_point_nodes, s.two_point_interactions, s.iterations
        )
    }
}

/// A point or direction given to `render` as three finite numbers.
fn vector(
    name: &str,
    value: Option<PyArrayLike1<'_, f64, AllowTypeChange>>,
) -> Result<Option<DVec3>> {
    let Some(value) = value else {
        return Ok(None);
    };
    let values: Vec<f64> = value.as_array().iter().copied().collect();
    match values[..] {
        [x, y, z] if values.iter().all(|v| v.is_finite()) => Ok(Some(DVec3::new(x, y, z))),
        _ => Err(Error::Argument(format!(
            "render: {name} needs three finite numbers, got {values:?}"
        ))),
    }
}

/// A row-major RGB buffer as an (height, width, 3) array.
fn pixels(py: Python<'_>, width: u32, height: u32, rgb: Vec<f32>) -> Bound<'_, PyArray3<f32>> {
    let shape = (height as usize, width as usize, 3);
    Array3::from_shape_vec(shape, rgb)
        .expect("images hold width * height * 3 values")
        .into_pyarray(py)
}

/// Load a Mitsuba 3 XML scene; keyword arguments override its `<default>`s.
#[pyfunction]
#[pyo3(signature = (path, **defines))]
fn load_scene(py: Python<'_>, path: PathBuf, defines: Option<&Bound<'_, PyDict>>) -> Result<Scene> {
    let mut overrides = Vec::new();
    for (name, value) in defines.into_iter().flatten() {
        overrides.push((name.extract::<String>()?, value.str()?.to_string()));
    }
    let scene = py.allow_threads(|| wavrad_io::load_scene_with(&path, &overrides))?;
    Ok(Scene(scene))
}

/// Solve `scene` with the settings given by name (those of
/// [`SolveSettings::SETTINGS`]); unset ones keep the defaults of the oracle.
#[pyfunction]
#[pyo3(signature = (scene, *, solver=None, on_step=None, **settings))]
fn solve(
    py: Python<'_>,
    scene: &Scene,
    solver: Option<&str>,
    on_step: Option<PyObject>,
    settings: Option<&Bound<'_, PyDict>>,
) -> Result<Solution> {
    let solver: Solver = solver.map_or(Ok(Solver::default()), str::parse)?;
    let settings = SolveSettings::from_values(&described_values::<SolveSettings>(settings)?)?;
    if on_step.is_some() && solver != Solver::Shoot {
        return Err(Error::Argument(
            "solve: on_step is called after each shooting step; it needs solver=\"shoot\"".into(),
        ));
    }
    // The callback runs with the GIL taken back; an exception it raises
    // stops shooting and is raised again here.
    let mut raised: Option<PyErr> = None;
    let mut step_callback = on_step.map(|callback| {
        let raised = &mut raised;
        move |solution: &wavrad_core::solve::Solution, step: &Step| {
            Python::with_gil(|py| match call_on_step(py, &callback, solution, step) {
                Ok(true) => ControlFlow::Continue(()),
                Ok(false) => ControlFlow::Break(()),
                Err(e) => {
                    *raised = Some(e);
                    ControlFlow::Break(())
                }
            })
        }
    });
    let solution = py.allow_threads(|| match solver {
        Solver::Gather => wavrad_core::solve::solve(&scene.0, &settings, &Silent),
        Solver::Shoot => solve_shooting(
            &scene.0,
            &settings,
            &Silent,
            step_callback
                .as_mut()
                .map(|f| f as wavrad_core::solve::shoot::OnStep<'_>),
        ),
    })?;
    if let Some(e) = raised {
        return Err(Error::Python(e));
    }
    Ok(Solution(Renderer::new(solution)))
}

/// Call `on_step(step, image)` after a shooting step: `step` a dict of the
/// step's numbers, `image` the solution so far as a quick preview of the
/// scene's sensor (None without one). Shooting goes on unless it returns
/// False.
fn call_on_step(
    py: Python<'_>,
    callback: &PyObject,
    solution: &wavrad_core::solve::Solution,
    step: &Step,
) -> PyResult<bool> {
    let info = PyDict::new(py);
    info.set_item("index", step.index)?;
    info.set_item("shooter", step.shooter)?;
    info.set_item("unshot_fraction", step.unshot_fraction)?;
    info.set_item("kernel_pairs", step.kernel_pairs)?;
    info.set_item("links", step.links)?;
    let image = match Renderer::new(solution).preview() {
        Ok(image) => pixels(py, image.width, image.height, image.rgb).into_any(),
        Err(_) => py.None().into_bound(py),
    };
    let answer = callback.call1(py, (info, image))?;
    Ok(!answer.bind(py).is(pyo3::types::PyBool::new(py, false)))
}

/// A core enum named by a Python string (`mode`, `oracle`, `solver`); an unknown
/// name is a `ValueError` listing the valid ones.
/// The keyword arguments `given` as values of the settings `S` describes.
fn described_values<S: Described>(
    given: Option<&Bound<'_, PyDict>>,
) -> Result<Vec<(&'static str, Value)>> {
    let Some(given) = given else {
        return Ok(Vec::new());
    };
    given
        .iter()
        .map(|(key, value)| {
            let name = key.extract::<String>()?;
            let setting = S::setting(&name).map_err(|_| {
                PyTypeError::new_err(format!("unexpected keyword argument {name:?}"))
            })?;
            let wrong = |kind: &str| {
                Error::Argument(format!("{}: expected {kind}, got {value}", setting.name))
            };
            let value = match setting.domain {
                Domain::Real { .. } => Value::Real(value.extract().map_err(|_| wrong("a number"))?),
                Domain::Count { .. } => {
                    Value::Count(value.extract().map_err(|_| wrong("a whole number >= 0"))?)
                }
                Domain::Flag => Value::Flag(value.extract().map_err(|_| wrong("True or False"))?),
                Domain::Choice(_) => {
                    return Ok((setting.name, setting.parse(&value.extract::<String>()?)?))
                }
            };
            Ok((setting.name, setting.check(value)?))
        })
        .collect()
}

/// Relative RMSE of `a` against the reference `b` (any shape, same size).
#[pyfunction]
fn relative_rmse(
    a: PyArrayLikeDyn<'_, f32, AllowTypeChange>,
    b: PyArrayLikeDyn<'_, f32, AllowTypeChange>,
) -> Result<f64> {
    if a.shape() != b.shape() {
        return Err(Error::Argument(format!(
            "relative_rmse needs arrays of one shape, got {:?} and {:?}",
            a.shape(),
            b.shape()
        )));
    }
    let a: Vec<f32> = a.as_array().iter().copied().collect();
    let b: Vec<f32> = b.as_array().iter().copied().collect();
    Ok(wavrad_io::relative_rmse(&a, &b))
}

/// Read the RGB channels of an OpenEXR file as an (height, width, 3) array.
#[pyfunction]
fn read_exr(py: Python<'_>, path: PathBuf) -> Result<Bound<'_, PyArray3<f32>>> {
    let (width, height, rgb) = py.allow_threads(|| wavrad_io::read_exr_rgb(&path))?;
    Ok(pixels(py, width, height, rgb))
}

/// Write an (height, width, 3) linear RGB array as `.exr` or `.png`.
#[pyfunction]
fn write_image(
    py: Python<'_>,
    path: PathBuf,
    image: PyArrayLike3<'_, f32, AllowTypeChange>,
) -> Result<()> {
    let [height, width, channels] = *image.shape() else {
        unreachable!("PyArrayLike3 is three-dimensional")
    };
    let (Ok(width), Ok(height), 3) = (u32::try_from(width), u32::try_from(height), channels) else {
        return Err(Error::Argument(format!(
            "write_image needs an (height, width, 3) array, got shape {:?}",
            image.shape()
        )));
    };
    let rgb: Vec<f32> = image.as_array().iter().copied().collect();
    py.allow_threads(|| wavrad_io::write_image(&path, width, height, &rgb))?;
    Ok(())
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("WavradError", py.get_type::<WavradError>())?;
    m.add("SceneError", py.get_type::<SceneError>())?;
    m.add("SolveError", py.get_type::<SolveError>())?;
    m.add_class::<Scene>()?;
    m.add_class::<Solution>()?;
    m.add_function(wrap_pyfunction!(load_scene, m)?)?;
    m.add_function(wrap_pyfunction!(solve, m)?)?;
    m.add_function(wrap_pyfunction!(relative_rmse, m)?)?;
    m.add_function(wrap_pyfunction!(read_exr, m)?)?;
    m.add_function(wrap_pyfunction!(write_image, m)?)?;
    Ok(())
}
