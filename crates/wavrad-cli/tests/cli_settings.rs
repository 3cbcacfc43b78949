//! The command line's options are the settings' descriptions: every
//! described setting is an option under its group with its default shown,
//! and the statistics JSON reports the settings by the same names.

mod support;

use support::{small_scene, wavrad, write};
use wavrad_core::render::RenderSettings;
use wavrad_core::setting::{Described, Domain};
use wavrad_core::solve::SolveSettings;

#[test]
fn help_lists_every_described_setting_under_its_group_with_its_default() {
    let o = wavrad(&["render", "--help"]);
    assert_eq!(o.status.code(), Some(0));
    let help = String::from_utf8_lossy(&o.stdout);
    for heading in [
        "Scene options",
        "Solve options",
        "Render options",
        "Output options",
    ] {
        assert!(help.contains(heading), "no {heading} in:\n{help}");
    }
    let described = SolveSettings::SETTINGS
        .iter()
        .chain(RenderSettings::SETTINGS);
    for setting in described {
        let flag = match (setting.domain, setting.default) {
            (Domain::Flag, "true") => format!("--no-{}", &setting.flag()[2..]),
            _ => setting.flag(),
        };
        assert!(help.contains(&flag), "{flag} missing from --help");
        if setting.domain != Domain::Flag {
            let default = format!("[default: {}]", setting.default);
            assert!(help.contains(&default), "{flag}: {default} missing");
        }
    }
}

#[test]
fn stats_report_the_settings_by_their_described_names() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write(dir.path(), "s.xml", &small_scene(""));
    let (out, stats) = (dir.path().join("out.exr"), dir.path().join("stats.json"));
    let o = wavrad(&[
        "render",
        &scene,
        "-o",
        out.to_str().unwrap(),
        "--stats",
        stats.to_str().unwrap(),
        "--max-level",
        "2",
        "--spp",
        "4",
        "--mode",
        "smooth",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", support::stderr(&o));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    for (group, names) in [
        ("settings", SolveSettings::SETTINGS),
        ("render", RenderSettings::SETTINGS),
    ] {
        let object = json[group].as_object().unwrap();
        let mut keys: Vec<&str> = object.keys().map(String::as_str).collect();
        let mut expected: Vec<&str> = names.iter().map(|s| s.name).collect();
        keys.sort_unstable();
        expected.sort_unstable();
        assert_eq!(keys, expected, "{group}");
    }
    assert_eq!(json["settings"]["max_level"], 2);
    assert_eq!(json["render"]["spp"], 4);
    assert_eq!(json["render"]["mode"], "smooth");
}
