//! The README is the newcomer's entry point: its two commands must be there,
//! every image it shows must exist, and it must not have been mangled by an
//! editing script (a bad replace once inserted a block between every
//! character: 279k lines).

use std::path::Path;

#[test]
fn readme_names_the_two_commands_and_its_images_exist() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("README.md")).expect("README.md");
    let lines = text.lines().count();
    assert!(lines < 1500, "README.md has {lines} lines: mangled?");
    assert!(
        text.starts_with("# deformlab"),
        "README.md must start with its title"
    );
    assert!(
        text.contains("cargo test --release"),
        "test command missing"
    );
    assert!(text.contains("deformlab run experiments/*.toml") || text.contains("run experiments/"));
    let mut images = 0;
    for part in text.split("](").skip(1) {
        let target = part.split(')').next().unwrap_or("");
        if target.ends_with(".png") && !target.starts_with("http") {
            images += 1;
            assert!(
                root.join(target).is_file(),
                "README shows missing image {target}"
            );
        }
    }
    assert!(images > 0, "no images found in README.md");
    let headers = text.matches("\n| | |\n").count();
    assert!(headers <= 1, "the results table appears {headers} times");
}
