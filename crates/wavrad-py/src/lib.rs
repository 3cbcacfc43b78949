//! Python bindings of wavrad: `wavrad._native`, re-exported by the `wavrad`
//! package (`python/wavrad`).
//!
//! This crate only converts and calls: Python arguments become core settings
//! and enums, numpy arrays become pixel buffers and back, and errors become
//! the exception tree of [`error`]. Every computation lives in `wavrad-core`
//! and every file format in `wavrad-io`.

mod error;
mod progress;

use std::path::PathBuf;

use glam::DVec3;
use numpy::ndarray::{Array2, Array3};
use numpy::{
    AllowTypeChange, IntoPyArray, PyArray2, PyArray3, PyArrayLike1, PyArrayLike3, PyArrayLikeDyn,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyUserWarning};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict, PyRange, PyRangeMethods};
use std::ops::ControlFlow;
use std::sync::Mutex;
use std::time::Duration;
use wavrad_core::progress::Silent;
use wavrad_core::render::{RenderSettings, Renderer};
use wavrad_core::scene::Rgb;
use wavrad_core::scene::Scene as CoreScene;
use wavrad_core::setting::{Described, Domain, Value};
use wavrad_core::solve::shoot::{solve_shooting, Step};
use wavrad_core::solve::{CheckpointView, Saver, SolveSettings, Solver};
use wavrad_io::block_links::{
    decode_items, decode_links, encode_items, encode_links, fingerprint, projector_fingerprint,
    Fingerprint,
};
use wavrad_io::solution_file::{
    read_solution, read_unfinished, write_checkpoint, write_solution, Source,
};

use error::{argument_error, Error, Result, SceneError, SolveError, SolveWarning, WavradError};
use progress::{PyProgress, Warnings};

/// A scene loaded from a Mitsuba 3 XML file, with where it came from (for
/// the solution files of its solutions).
#[pyclass(module = "wavrad", frozen)]
struct Scene(wavrad_core::scene::Scene, Option<Source>);

#[pymethods]
impl Scene {
    /// Number of surfaces (two-sided materials count twice).
    #[getter]
    fn surface_count(&self) -> usize {
        self.0.surfaces.len()
    }

    /// Number of sensors (`Solution.render(sensor=N)` renders the N-th,
    /// from 0).
    #[getter]
    fn sensor_count(&self) -> usize {
        self.0.sensor_count()
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

/// A view-independent radiance solution, with the renderer of its views and
/// where its scene came from.
#[pyclass(module = "wavrad", frozen)]
struct Solution(Renderer, Option<Source>);

#[pymethods]
impl Solution {
    /// Write the solution to `path` (a solution file, read back by
    /// `load_solution`), atomically.
    fn save(&self, py: Python<'_>, path: PathBuf) -> Result<()> {
        py.allow_threads(|| write_solution(&path, self.0.solution(), self.1.as_ref()))?;
        Ok(())
    }

    /// Render the scene's sensor (`sensor`, numbered from 0; the first by
    /// default), or another view of the solution (moved by Mitsuba's
    /// look_at `origin`/`target`/`up`, `fov` in degrees along the sensor's
    /// `fov_axis`); returns an (height, width, 3) float32 array of linear
    /// RGB radiance. The render settings (`mode`, `spp`, and by keyword
    /// `gather_spp`, `eye`, `gather_cache`, `seed`) are those of
    /// [`RenderSettings::SETTINGS`]. Ctrl-C stops the render and raises
    /// `KeyboardInterrupt`.
    #[pyo3(signature = (mode=None, spp=None, *, sensor=0, origin=None, target=None, up=None, fov=None, progress=None, **settings))]
    #[allow(clippy::too_many_arguments)] // keyword arguments of the Python API
    fn render<'py>(
        &self,
        py: Python<'py>,
        mode: Option<&str>,
        spp: Option<u32>,
        sensor: usize,
        origin: Option<PyArrayLike1<'py, f64, AllowTypeChange>>,
        target: Option<PyArrayLike1<'py, f64, AllowTypeChange>>,
        up: Option<PyArrayLike1<'py, f64, AllowTypeChange>>,
        fov: Option<f64>,
        progress: Option<&Bound<'py, PyAny>>,
        settings: Option<&Bound<'py, PyDict>>,
    ) -> Result<Bound<'py, PyArray3<f32>>> {
        let progress = PyProgress::new(py, progress)?.raising_interrupts();
        let scene = &self.0.solution().scene;
        let sensor = scene.sensor(sensor)?;
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
        let settings = RenderSettings::from_values(&sensor.hints, &given)?;
        let (mut camera, film) = (sensor.camera, sensor.film);
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
            let aspect = f64::from(film.width) / f64::from(film.height);
            camera = camera.with_fov(fov, aspect).ok_or_else(|| {
                Error::Argument(if fov > 0.0 && fov < 180.0 {
                    "render: fov needs a perspective sensor, the scene's is orthographic".into()
                } else {
                    format!("render: fov = {fov} is outside (0, 180) degrees")
                })
            })?;
        }
        let image = progress.watch(py, || {
            self.0.render_view(&camera, &film, &settings, &progress)
        })??;
        Ok(pixels(py, image.width, image.height, image.rgb))
    }

    /// Average radiance of every element: an (elements, 3) float64 array,
    /// surfaces in scene order, each surface's element hierarchy in the
    /// order of its nodes.
    #[getter]
    fn radiance<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, &self.0.solution().radiance)
    }

    /// Average directional radiance of every element pair of every glossy
    /// surface's directional structures, in the same way.
    #[getter]
    fn directional<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(py, &self.0.solution().directional)
    }

    /// Whether the solve was cut short and can be resumed
    /// (`wavrad.solve(scene, resume=this)`): how many projection items it
    /// finished and how many it has, or None when it ran to the end.
    #[getter]
    fn checkpoint(&self) -> Option<(usize, usize)> {
        let checkpoint = self.0.solution().checkpoint.as_ref()?;
        Some((checkpoint.finished_items(), checkpoint.items))
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

/// Per-node colours of several trees as one (nodes, 3) array, in order.
fn rows<'py>(py: Python<'py>, trees: &[Vec<Rgb>]) -> Bound<'py, PyArray2<f64>> {
    let values: Vec<f64> = trees.iter().flatten().flat_map(|c| c.0).collect();
    Array2::from_shape_vec((values.len() / 3, 3), values)
        .expect("three channels per node")
        .into_pyarray(py)
}

/// A gathering solve planned up to its kernel projection (`wavrad.plan`),
/// whose items other processes can project in blocks.
#[pyclass(module = "wavrad")]
struct Plan {
    /// Where the planned scene came from.
    source: Option<Source>,
    /// `None` once finished (the solution took its scene and ray queries).
    plan: Option<wavrad_core::solve::Plan>,
    fingerprint: Fingerprint,
}

impl Plan {
    fn planned(&self) -> Result<&wavrad_core::solve::Plan> {
        self.plan
            .as_ref()
            .ok_or_else(|| Error::Argument("this plan was finished; plan the scene again".into()))
    }
}

#[pymethods]
impl Plan {
    /// Projection items: element pairs, then surface triples.
    fn __len__(&self) -> Result<usize> {
        Ok(self.planned()?.items().end)
    }

    /// The items in at most `n` consecutive blocks (`range`s) of sizes that
    /// differ by one at most.
    fn blocks<'py>(&self, py: Python<'py>, n: usize) -> Result<Vec<Bound<'py, PyRange>>> {
        let blocks = self.planned()?.blocks(n);
        let range = |b: std::ops::Range<usize>| {
            PyRange::new(py, b.start as isize, b.end as isize).map_err(Error::from)
        };
        blocks.into_iter().map(range).collect()
    }

    /// Project the items in `block` (a `range` with step 1) and return
    /// their links as bytes for `finish`.
    fn project<'py>(
        &self,
        py: Python<'py>,
        block: &Bound<'py, PyRange>,
    ) -> Result<Bound<'py, PyBytes>> {
        let plan = self.planned()?;
        let block = items_of("project", block)?;
        let bytes = py.allow_threads(|| {
            plan.project(block, &Silent)
                .map(|links| encode_links(self.fingerprint, &links))
        })?;
        Ok(PyBytes::new(py, &bytes))
    }

    /// The items in `block` (a `range` with step 1) as bytes, for a
    /// `Projector` of the same scene and settings.
    fn items<'py>(
        &self,
        py: Python<'py>,
        block: &Bound<'py, PyRange>,
    ) -> Result<Bound<'py, PyBytes>> {
        let items = self.planned()?.block_items(items_of("items", block)?)?;
        Ok(PyBytes::new(py, &encode_items(self.fingerprint, &items)))
    }

    /// Solve from the projected `blocks` (the bytes `project` returned,
    /// every item once, in any order); the plan is used up.
    fn finish(&mut self, py: Python<'_>, blocks: Vec<Bound<'_, PyBytes>>) -> Result<Solution> {
        let fingerprint = self.fingerprint;
        let bytes: Vec<&[u8]> = blocks.iter().map(|b| b.as_bytes()).collect();
        let links = py.allow_threads(|| {
            bytes
                .iter()
                .map(|b| decode_links(b, fingerprint))
                .collect::<wavrad_io::Result<Vec<_>>>()
        })?;
        self.planned()?.check_cover(&links)?;
        let plan = self.plan.take().expect("checked above");
        let told = Warnings::default();
        let solution = py.allow_threads(|| plan.finish(links, &told))?;
        told.raise(py)?;
        warn_solve_end(py, &solution)?;
        Ok(Solution(Renderer::new(solution), self.source.clone()))
    }

    /// The two-point and three-point links in `block`, bytes that `project`
    /// of this plan returned.
    fn links_in(&self, py: Python<'_>, block: &Bound<'_, PyBytes>) -> Result<(usize, usize)> {
        let bytes = block.as_bytes();
        let links = py.allow_threads(|| decode_links(bytes, self.fingerprint))?;
        Ok((links.two_point.len(), links.three_point.len()))
    }

    /// Every setting of the plan by the name `plan` takes it: planning
    /// again with them makes the same plan.
    #[getter]
    fn settings<'py>(&self, py: Python<'py>) -> Result<Bound<'py, PyDict>> {
        let settings = PyDict::new(py);
        for (name, value) in self.planned()?.projector().settings().values() {
            match value {
                Value::Real(x) => settings.set_item(name, x)?,
                Value::Count(n) => settings.set_item(name, n)?,
                Value::Flag(b) => settings.set_item(name, b)?,
                Value::Choice(choice) => settings.set_item(name, choice)?,
            }
        }
        Ok(settings)
    }

    /// The CRC-32 of the plan's scene, settings and items, which its blocks
    /// carry.
    #[getter]
    fn fingerprint(&self) -> u32 {
        self.fingerprint.plan
    }

    /// The CRC-32 of the plan's scene and settings: that of a `Projector`
    /// that can project its items.
    #[getter]
    fn projector_fingerprint(&self) -> u32 {
        self.fingerprint.projector
    }

    fn __repr__(&self) -> String {
        match &self.plan {
            Some(plan) => format!(
                "Plan(element_pairs={}, triples={}, cluster_links={})",
                plan.element_pairs().len(),
                plan.triples().len(),
                plan.cluster_links().len()
            ),
            None => "Plan(finished)".into(),
        }
    }
}

/// The items of a block given as a `range` with step 1, to `function`.
fn items_of(function: &str, block: &Bound<'_, PyRange>) -> Result<std::ops::Range<usize>> {
    let (start, stop, step) = (block.start()?, block.stop()?, block.step()?);
    match (usize::try_from(start), usize::try_from(stop), step) {
        (Ok(start), Ok(stop), 1) => Ok(start..stop),
        _ => Err(Error::Argument(format!(
            "{function}: a block is a range of items with step 1, got range({start}, {stop}, {step})"
        ))),
    }
}

/// What projects a plan's items in another process (`wavrad.projector`):
/// the scene, its ray queries and the settings, without the linking.
#[pyclass(module = "wavrad", frozen)]
struct Projector {
    projector: wavrad_core::solve::Projector,
    fingerprint: u32,
}

#[pymethods]
impl Projector {
    /// Project the items in `items` (bytes from `Plan.items` of a plan of
    /// the same scene and settings) and return their links as bytes for
    /// that plan's `finish`.
    fn project<'py>(
        &self,
        py: Python<'py>,
        items: &Bound<'py, PyBytes>,
    ) -> Result<Bound<'py, PyBytes>> {
        let bytes = items.as_bytes();
        let links = py.allow_threads(|| {
            decode_items(bytes, self.fingerprint).map(|(fingerprint, items)| {
                encode_links(fingerprint, &self.projector.project(&items, &Silent))
            })
        })?;
        Ok(PyBytes::new(py, &links))
    }

    /// The CRC-32 of the scene and settings, which `Plan.projector_fingerprint`
    /// of a plan whose items it can project equals.
    #[getter]
    fn fingerprint(&self) -> u32 {
        self.fingerprint
    }

    fn __repr__(&self) -> String {
        format!(
            "Projector(surfaces={}, fingerprint={:08x})",
            self.projector.scene().surfaces.len(),
            self.fingerprint
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
/// `approximate` replaces unsupported BSDFs and textures by the nearest
/// supported model (one warning per plugin). The loader's warnings become
/// Python `UserWarning`s.
#[pyfunction]
#[pyo3(signature = (path, *, approximate=false, **defines))]
fn load_scene(
    py: Python<'_>,
    path: PathBuf,
    approximate: bool,
    defines: Option<&Bound<'_, PyDict>>,
) -> Result<Scene> {
    let mut overrides = Vec::new();
    for (name, value) in defines.into_iter().flatten() {
        overrides.push((name.extract::<String>()?, value.str()?.to_string()));
    }
    let options = wavrad_io::LoadOptions { approximate };
    let loaded =
        py.allow_threads(|| wavrad_io::load_scene_with_options(&path, &overrides, options))?;
    let warnings = py.import("warnings")?;
    for warning in &loaded.warnings {
        let category = py.get_type::<PyUserWarning>();
        warnings.call_method1("warn", (warning.to_string(), category, 2))?;
    }
    // A scene whose file cannot be named again has no source to check.
    let source = Source::new(&path, &overrides, options).ok();
    Ok(Scene(loaded.scene, source))
}

/// Solve `scene` with the settings given by name (those of
/// [`SolveSettings::SETTINGS`]); unset ones keep the defaults of the oracle.
/// With `resume` (a solution, or the path of a solution file, cut short),
/// resume its solve ([`wavrad_core::solve::resume`]) with its settings,
/// those given set on top.
#[pyfunction]
#[pyo3(signature = (
    scene, *, solver=None, on_step=None, progress=None, resume=None, checkpoint=None,
    checkpoint_every=300.0, **settings
))]
#[allow(clippy::too_many_arguments)]
fn solve(
    py: Python<'_>,
    scene: &Scene,
    solver: Option<&str>,
    on_step: Option<PyObject>,
    progress: Option<&Bound<'_, PyAny>>,
    resume: Option<&Bound<'_, PyAny>>,
    checkpoint: Option<PathBuf>,
    checkpoint_every: f64,
    settings: Option<&Bound<'_, PyDict>>,
) -> Result<Solution> {
    let progress = PyProgress::new(py, progress)?;
    let solver: Solver = solver.map_or(Ok(Solver::default()), str::parse)?;
    let given = described_values::<SolveSettings>(settings)?;
    if let Some(resume) = resume {
        if solver != Solver::Gather || on_step.is_some() {
            return Err(Error::Argument(
                "solve: resume resumes a gathering solve; solver=\"shoot\" and on_step do not \
                 go with it"
                    .into(),
            ));
        }
        let read;
        let from = match resume.downcast::<Solution>() {
            Ok(solution) => solution.get().0.solution().unfinished().ok_or_else(|| {
                wavrad_core::Error::Resume(
                    "the solve ran to the end: nothing is left to resume".into(),
                )
            })?,
            Err(_) => {
                let path: PathBuf = resume.extract().map_err(|_| {
                    Error::Argument(format!(
                        "solve: resume expects a Solution or the path of a solution or \
                         checkpoint file, got {resume}"
                    ))
                })?;
                read = py.allow_threads(|| read_unfinished(&path))?;
                warn_all(py, &read.warnings)?;
                read.unfinished()
            }
        };
        let settings = from.settings.for_resuming(&given)?;
        let saving = checkpoint_saver(checkpoint.as_deref(), checkpoint_every, scene)?;
        let solution = progress.watch(py, || {
            with_saver(saving.as_ref(), |saver| {
                wavrad_core::solve::resume(&scene.0, &settings, from, saver, &progress)
            })
        })??;
        warn_unsaved(py, saving)?;
        warn_solve_end(py, &solution)?;
        return Ok(Solution(Renderer::new(solution), scene.1.clone()));
    }
    let saving = checkpoint_saver(checkpoint.as_deref(), checkpoint_every, scene)?;
    if saving.is_some() && solver != Solver::Gather {
        return Err(Error::Argument(
            "solve: checkpoint saves a gathering solve's kernels; solver=\"shoot\" does not \
             save checkpoints"
                .into(),
        ));
    }
    let settings = SolveSettings::from_values(&given)?;
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
    let solution = progress.watch(py, || match solver {
        Solver::Gather => with_saver(saving.as_ref(), |saver| {
            wavrad_core::solve::solve_saving(&scene.0, &settings, saver, &progress)
        }),
        Solver::Shoot => solve_shooting(
            &scene.0,
            &settings,
            &progress,
            step_callback
                .as_mut()
                .map(|f| f as wavrad_core::solve::shoot::OnStep<'_>),
        ),
    })??;
    if let Some(e) = raised {
        return Err(Error::Python(e));
    }
    warn_unsaved(py, saving)?;
    warn_solve_end(py, &solution)?;
    Ok(Solution(Renderer::new(solution), scene.1.clone()))
}

/// A `wavrad.SolveWarning` saying what cut `solution`'s solve short, if
/// anything did ([`Stats::cut_short_warning`](wavrad_core::solve::stats::Stats::cut_short_warning)),
/// or that Gauss–Seidel did not converge
/// ([`Stats::not_converged_warning`](wavrad_core::solve::stats::Stats::not_converged_warning)).
fn warn_solve_end(py: Python<'_>, solution: &wavrad_core::solve::Solution) -> PyResult<()> {
    let stats = &solution.stats;
    if let Some(message) = stats.cut_short_warning() {
        progress::warn(py, &message)?;
    }
    match stats.not_converged_warning(solution.settings.tolerance) {
        Some(message) => {
            progress::warn(py, &format!("{message}; a larger max_iterations may help"))
        }
        None => Ok(()),
    }
}

/// Checkpoints of a solve saved to a file ([`solve`]'s `checkpoint`).
struct CheckpointSaving<'a> {
    path: PathBuf,
    every: Duration,
    source: Option<&'a Source>,
    /// The first failure to save, the solve going on.
    failed: Mutex<Option<wavrad_io::Error>>,
}

impl CheckpointSaving<'_> {
    /// Save what `view` shows of a solve of `scene` with `settings`.
    fn save(&self, scene: &CoreScene, settings: &SolveSettings, view: CheckpointView<'_>) {
        if let Err(e) = write_checkpoint(&self.path, scene, settings, view, self.source) {
            let mut failed = self.failed.lock().unwrap_or_else(|e| e.into_inner());
            failed.get_or_insert(e);
        }
    }
}

/// `work` given the saver of `saving`, if any.
fn with_saver<R>(saving: Option<&CheckpointSaving>, work: impl FnOnce(Option<&Saver>) -> R) -> R {
    let save = |scene: &CoreScene, settings: &SolveSettings, view: CheckpointView<'_>| {
        if let Some(saving) = saving {
            saving.save(scene, settings, view)
        }
    };
    let saver = saving.map(|saving| Saver {
        every: saving.every,
        save: &save,
    });
    work(saver.as_ref())
}

/// A `UserWarning` for the first checkpoint `saving` failed to save.
fn warn_unsaved(py: Python<'_>, saving: Option<CheckpointSaving>) -> PyResult<()> {
    let failed = saving.and_then(|s| s.failed.into_inner().unwrap_or_else(|e| e.into_inner()));
    match failed {
        Some(e) => warn_all(py, &[format!("a checkpoint could not be saved: {e}")]),
        None => Ok(()),
    }
}

/// Where to save `scene`'s checkpoints (`path`, every `every` seconds),
/// if anywhere.
fn checkpoint_saver<'a>(
    path: Option<&std::path::Path>,
    every: f64,
    scene: &'a Scene,
) -> Result<Option<CheckpointSaving<'a>>> {
    let Some(path) = path else { return Ok(None) };
    if !(every.is_finite() && every > 0.0) {
        return Err(Error::Argument(format!(
            "solve: checkpoint_every is {every}: seconds, more than 0"
        )));
    }
    wavrad_io::check_writable(path)?;
    Ok(Some(CheckpointSaving {
        path: path.to_path_buf(),
        every: Duration::from_secs_f64(every),
        source: scene.1.as_ref(),
        failed: Mutex::new(None),
    }))
}

/// Each of `warnings` as a Python `UserWarning`.
fn warn_all(py: Python<'_>, warnings: &[String]) -> PyResult<()> {
    let module = py.import("warnings")?;
    for warning in warnings {
        let category = py.get_type::<PyUserWarning>();
        module.call_method1("warn", (warning.as_str(), category, 3))?;
    }
    Ok(())
}

/// Read a solution file written by `Solution.save` (or `wavrad solve -o`).
#[pyfunction]
fn load_solution(py: Python<'_>, path: PathBuf) -> Result<Solution> {
    let read = py.allow_threads(|| read_solution(&path))?;
    warn_all(py, &read.warnings)?;
    Ok(Solution(Renderer::new(read.solution), read.source))
}

/// Plan the gathering solve of `scene` with the settings given by name (as
/// `solve`'s), for its kernels to be projected in blocks elsewhere.
#[pyfunction]
#[pyo3(signature = (scene, **settings))]
fn plan(py: Python<'_>, scene: &Scene, settings: Option<&Bound<'_, PyDict>>) -> Result<Plan> {
    let settings = SolveSettings::from_values(&described_values::<SolveSettings>(settings)?)?;
    let told = Warnings::default();
    let plan = py.allow_threads(|| wavrad_core::solve::plan(&scene.0, &settings, &told))?;
    told.raise(py)?;
    Ok(Plan {
        source: scene.1.clone(),
        fingerprint: fingerprint(&plan),
        plan: Some(plan),
    })
}

/// What projects the items of plans of `scene` with the settings given by
/// name (as `solve`'s), in a process that did not plan.
#[pyfunction]
#[pyo3(signature = (scene, **settings))]
fn projector(
    py: Python<'_>,
    scene: &Scene,
    settings: Option<&Bound<'_, PyDict>>,
) -> Result<Projector> {
    let settings = SolveSettings::from_values(&described_values::<SolveSettings>(settings)?)?;
    let projector = py.allow_threads(|| wavrad_core::solve::Projector::new(&scene.0, &settings))?;
    Ok(Projector {
        fingerprint: projector_fingerprint(&projector),
        projector,
    })
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
    m.add("ArgumentError", argument_error(py)?)?;
    m.add("SolveWarning", py.get_type::<SolveWarning>())?;
    m.add_class::<Scene>()?;
    m.add_class::<Solution>()?;
    m.add_class::<Plan>()?;
    m.add_class::<Projector>()?;
    m.add_function(wrap_pyfunction!(load_scene, m)?)?;
    m.add_function(wrap_pyfunction!(load_solution, m)?)?;
    m.add_function(wrap_pyfunction!(solve, m)?)?;
    m.add_function(wrap_pyfunction!(plan, m)?)?;
    m.add_function(wrap_pyfunction!(projector, m)?)?;
    m.add_function(wrap_pyfunction!(relative_rmse, m)?)?;
    m.add_function(wrap_pyfunction!(read_exr, m)?)?;
    m.add_function(wrap_pyfunction!(write_image, m)?)?;
    Ok(())
}
