//! Running the `wavrad` binary from integration tests.

use std::path::Path;
use std::process::{Command, Output};

/// Run `wavrad` with `args` and collect its output.
pub fn wavrad(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wavrad"))
        .args(args)
        .output()
        .expect("run wavrad")
}

/// The run's standard error as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Write `text` to `dir/name` and return the path.
pub fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.display().to_string()
}

/// An emitter over a floor, seen by a small sensor (8×6); `floor_bsdf` goes
/// into the floor's shape.
pub fn small_scene(floor_bsdf: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <transform name="to_world"><lookat origin="0,0,3" target="0,0,0" up="0,1,0"/></transform>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film>
    </sensor>
    <shape type="rectangle"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="-90"/><translate y="-1" z="1"/></transform>
        {floor_bsdf}
    </shape>
</scene>
"#
    )
}
