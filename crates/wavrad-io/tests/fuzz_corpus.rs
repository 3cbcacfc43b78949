//! The committed fuzz corpora (`fuzz/corpus/TARGET/`: the seeds, and the
//! inputs fuzzing found bugs with) run through the fuzz targets' own entry
//! points, on the stable toolchain, in seconds: a regression suite that CI
//! runs. The fuzzing itself is `make fuzz` (docs/fuzzing.md).

use std::fs;
use std::path::Path;

#[path = "../../../fuzz/src/lib.rs"]
mod fuzz_targets;

#[test]
fn every_corpus_file_reads_without_a_panic() {
    let (_dir, workspace) = fuzz_targets::Workspace::temporary();
    let corpora = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus");
    for (target, run) in fuzz_targets::TARGETS {
        let mut files: Vec<_> = fs::read_dir(corpora.join(target))
            .unwrap_or_else(|e| panic!("the corpus of {target}: {e}"))
            .map(|entry| entry.unwrap().path())
            .collect();
        files.sort();
        assert!(!files.is_empty(), "the corpus of {target} is empty");
        for file in files {
            // Shown with the panic, if there is one.
            println!("{target}: {}", file.display());
            run(&workspace, &fs::read(&file).unwrap());
        }
    }
}
