//! Checkpoint files: what a solve under way has finished
//! ([`wavrad_core::solve::Saver`]), saved so that a run killed outright can
//! be resumed ([`wavrad_core::solve::resume`]) without projecting again
//! what it had finished.

use super::check::{check_settings, inconsistent};
use super::{
    check_source, decode, file_bytes, read_file, solution_of, write_body, SolutionProblem, Source,
};
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::path::Path;
use wavrad_core::scene::Scene;
use wavrad_core::solve::{Checkpoint, CheckpointView, SolveSettings, Unfinished};

/// The first bytes of a checkpoint file (the header is a solution file's,
/// [`super::MAGIC`] aside).
pub const CHECKPOINT_MAGIC: [u8; 8] = *b"wavradCP";

/// A checkpoint file's body: `C` is a [`CheckpointView`] to write and a
/// [`Checkpoint`] when read (they serialise alike).
#[derive(Serialize, Deserialize)]
struct Body<'a, C> {
    source: Option<Cow<'a, Source>>,
    scene: Cow<'a, Scene>,
    settings: SolveSettings,
    checkpoint: C,
}

/// Write what a solve under way of `scene` with `settings` has finished
/// (`checkpoint`) to `path`, atomically, with the `source` its scene was
/// loaded from, if any.
pub fn write_checkpoint(
    path: &Path,
    scene: &Scene,
    settings: &SolveSettings,
    checkpoint: CheckpointView<'_>,
    source: Option<&Source>,
) -> Result<()> {
    let body = Body {
        source: source.map(Cow::Borrowed),
        scene: Cow::Borrowed(scene),
        settings: *settings,
        checkpoint,
    };
    write_body(path, &CHECKPOINT_MAGIC, &body)
}

/// The bytes of a checkpoint file whose body, before compression, is
/// `encoded`, as [`super::solution_file_bytes`] makes a solution file's.
pub fn checkpoint_file_bytes(encoded: &[u8]) -> std::io::Result<Vec<u8>> {
    file_bytes(&CHECKPOINT_MAGIC, encoded)
}

/// A solve to resume, read from a file ([`read_unfinished`]).
pub struct ReadUnfinished {
    /// The scene it solved.
    pub scene: Scene,
    /// Its settings.
    pub settings: SolveSettings,
    /// What it had finished.
    pub checkpoint: Checkpoint,
    /// Where its scene came from, if it was written with one.
    pub source: Option<Source>,
    /// What users should be told (its scene file is not there to check).
    pub warnings: Vec<String>,
}

impl ReadUnfinished {
    /// The solve to resume.
    pub fn unfinished(&self) -> Unfinished<'_> {
        Unfinished {
            scene: &self.scene,
            settings: &self.settings,
            checkpoint: &self.checkpoint,
        }
    }
}

/// Read the solve to resume in `path`: a checkpoint file, or a solution
/// file of a solve that was cut short. Its scene file, if it was written
/// with one and is still there, must load to the scene solved, as for
/// [`super::read_solution`].
///
/// # Errors
/// [`Error::Io`] if the file cannot be read; [`Error::Solution`] if it is
/// neither kind of file, is of another format version, is truncated or
/// damaged, its scene changed, or it is a solution that ran to the end.
pub fn read_unfinished(path: &Path) -> Result<ReadUnfinished> {
    let bytes = read_file(path)?;
    if !bytes.starts_with(&CHECKPOINT_MAGIC) {
        let read = solution_of(path, &bytes)?;
        let solution = read.solution;
        let checkpoint = (solution.checkpoint)
            .ok_or_else(|| Error::solution(path, SolutionProblem::Finished))?;
        return Ok(ReadUnfinished {
            scene: solution.scene,
            settings: solution.settings,
            checkpoint,
            source: read.source,
            warnings: read.warnings,
        });
    }
    let (_, body): (String, Body<'static, Checkpoint>) =
        decode(&CHECKPOINT_MAGIC, &bytes).map_err(|p| Error::solution(path, p))?;
    let scene = body.scene.into_owned();
    // What a resume follows is checked there (the checkpoint against the
    // scene, the scene against the one loaded); the ray queries' BVH needs
    // its coordinates within bounds before that comparison.
    (scene.check_bounds()).map_err(|e| Error::solution(path, inconsistent("the scene", e)))?;
    check_settings(&body.settings)
        .map_err(|e| Error::solution(path, inconsistent("the settings", e)))?;
    let source = body.source.map(Cow::into_owned);
    let mut warnings = Vec::new();
    if let Some(source) = &source {
        warnings.extend(check_source(path, source, &scene)?);
    }
    Ok(ReadUnfinished {
        scene,
        settings: body.settings,
        checkpoint: body.checkpoint,
        source,
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solution_file::{read_solution, write_solution};
    use std::sync::Mutex;
    use std::time::Duration;
    use wavrad_core::progress::Silent;
    use wavrad_core::solve::{resume, solve, solve_saving, Saver};

    /// The bundled glossy Cornell box: element pairs and surface triples.
    const SCENE: &str = include_str!("../../../../scenes/glossy-cornell-box/scene.xml");

    #[test]
    fn a_saved_checkpoint_resumes_to_the_whole_solve_and_is_not_a_solution() {
        let dir = tempfile::tempdir().unwrap();
        let scene_path = dir.path().join("scene.xml");
        std::fs::write(&scene_path, SCENE).unwrap();
        let scene = crate::load_scene_with(&scene_path, &[]).unwrap().scene;
        let source = Source::new(&scene_path, &[], Default::default()).unwrap();
        let mut settings = SolveSettings::default();
        settings.refine.max_level = 3;
        let whole = solve(&scene, &settings, &Silent).unwrap();

        // Every save goes to the same file, as the CLI's do.
        let path = dir.path().join("scene.wavrad.checkpoint");
        let saves = Mutex::new(Vec::new());
        let save = |scene: &Scene, settings: &SolveSettings, view: CheckpointView<'_>| {
            write_checkpoint(&path, scene, settings, view.clone(), Some(&source)).unwrap();
            let read = read_unfinished(&path).unwrap();
            assert_eq!(read.checkpoint, view.to_checkpoint());
            saves.lock().unwrap().push(read.checkpoint.finished_items());
        };
        let saver = Saver {
            every: Duration::ZERO,
            save: &save,
        };
        solve_saving(&scene, &settings, Some(&saver), &Silent).unwrap();
        assert!(!saves.into_inner().unwrap().is_empty());

        // The last save, read back, resumes to the whole solve.
        let read = read_unfinished(&path).unwrap();
        assert!(read.warnings.is_empty(), "{:?}", read.warnings);
        assert_eq!(read.source.as_ref(), Some(&source));
        let resumed = resume(&scene, &settings, read.unfinished(), None, &Silent).unwrap();
        assert_eq!(resumed.radiance, whole.radiance);

        // It is not a solution to render, and a whole solution has nothing
        // to resume.
        let problem = |result: Result<()>| match result {
            Err(Error::Solution { problem, .. }) => problem.to_string(),
            Err(e) => panic!("another error: {e}"),
            Ok(()) => panic!("read"),
        };
        let refused = problem(read_solution(&path).map(|_| ()));
        assert!(refused.contains("--resume"), "{refused}");
        let solution = dir.path().join("whole.wavrad");
        write_solution(&solution, &whole, None).unwrap();
        let refused = problem(read_unfinished(&solution).map(|_| ()));
        assert!(refused.contains("ran to the end"), "{refused}");

        // Cut short, or with its scene edited since, it is refused.
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 1]).unwrap();
        let refused = problem(read_unfinished(&path).map(|_| ()));
        assert!(refused.contains("truncated"), "{refused}");
        std::fs::write(&path, &bytes).unwrap();
        std::fs::write(&scene_path, SCENE.replace("18.387,", "18.4,")).unwrap();
        let refused = problem(read_unfinished(&path).map(|_| ()));
        assert!(refused.contains("scene changed"), "{refused}");
    }
}
