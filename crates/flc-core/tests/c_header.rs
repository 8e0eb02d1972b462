//! `include/flc.h` is generated from `src/capi/` (`mod.rs` and its modules) by cbindgen (config `cbindgen.toml`). This test
//! regenerates it in memory and fails when the committed header differs.
//!
//! Update the header: `FLC_UPDATE_HEADER=1 cargo test -p flc-core --test c_header`.

use std::path::Path;

#[test]
fn header_is_up_to_date() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_src(dir.join("src/capi/mod.rs"))
        .generate()
        .expect("cbindgen failed on src/capi/");
    let mut generated = Vec::new();
    bindings.write(&mut generated);
    let generated = String::from_utf8(generated).expect("header is UTF-8");
    let path = dir.join("include/flc.h");
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    if generated == committed {
        return;
    }
    if std::env::var_os("FLC_UPDATE_HEADER").is_some_and(|v| v == "1") {
        std::fs::write(&path, &generated).expect("write include/flc.h");
        eprintln!("updated {}", path.display());
        return;
    }
    let first_diff = generated
        .lines()
        .zip(committed.lines())
        .position(|(a, b)| a != b)
        .unwrap_or_else(|| generated.lines().count().min(committed.lines().count()));
    panic!(
        "crates/flc-core/include/flc.h is out of date with src/capi/ (first difference at line {}).\n\
         Regenerate it with:\n    FLC_UPDATE_HEADER=1 cargo test -p flc-core --test c_header\n",
        first_diff + 1
    );
}
