//! Malformed input: each error names the right file, line and column.

use std::path::{Path, PathBuf};

use pbrt::ParseError;

fn err(text: &str) -> ParseError {
    match pbrt::parse_str(text, Path::new("dir/bad.pbrt")) {
        Ok(_) => panic!("parsed without error:\n{text}"),
        Err(e) => e,
    }
}

/// Asserts the error is at `line:column` of `dir/bad.pbrt` and its message contains `needle`.
#[track_caller]
fn check(text: &str, line: u32, column: u32, needle: &str) {
    let e = err(text);
    let s = e.to_string();
    assert!(s.starts_with(&format!("dir/bad.pbrt:{line}:{column}: error: ")), "{s}");
    assert!(e.message.contains(needle), "{s}");
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("prismatic-pbrt-err-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn unterminated_string() {
    check("WorldBegin\nShape \"sphere\n", 2, 7, "unterminated string");
}

#[test]
fn unknown_directive() {
    check("WorldBegin\n  Shape \"sphere\"\n  Sphere \"x\"", 3, 3, "unknown directive 'Sphere'");
}

#[test]
fn bad_number() {
    check("WorldBegin\nShape \"sphere\" \"float radius\" [ 1.2.3 ]", 2, 33, "'1.2.3'");
    check("LookAt 0 0 1 0 0 0 0 1 x0\nWorldBegin", 1, 24, "number");
}

#[test]
fn unbalanced_brackets() {
    check("WorldBegin\nShape \"sphere\" \"float radius\" [ 1\nShape \"disk\"", 2, 31, "']'");
    check("WorldBegin\nShape \"sphere\" ]", 2, 16, "expected a directive, found ']'");
    check("WorldBegin\nShape \"sphere\" \"float radius\" [ 1 [ 2 ] ]", 2, 35, "'['");
}

#[test]
fn attribute_end_without_begin() {
    check(
        "WorldBegin\nAttributeBegin\nAttributeEnd\nAttributeEnd",
        4,
        1,
        "AttributeEnd without a matching AttributeBegin",
    );
    check("WorldBegin\n\nAttributeBegin\nShape \"sphere\"", 3, 1, "AttributeBegin without a matching AttributeEnd");
    check("WorldBegin\nObjectBegin \"a\"\nAttributeEnd", 3, 1, "ObjectBegin");
}

#[test]
fn missing_include_names_the_include_line() {
    check("WorldBegin\n\n   Include \"nowhere/x.pbrt\"", 3, 4, "nowhere/x.pbrt");
}

#[test]
fn wrong_parameter_type() {
    check("WorldBegin\nShape \"sphere\" \"float radius\" [ 1 \"two\" ]", 2, 35, "expects numbers");
    check("WorldBegin\nShape \"mesh\" \"integer indices\" [ 0 1.5 2 ]", 2, 36, "integer");
    check("WorldBegin\nShape \"sphere\" \"string name\" 7", 2, 30, "quoted strings");
    check("WorldBegin\nShape \"sphere\" \"bool flag\" yes", 2, 28, "true or false");
    check("WorldBegin\nShape \"sphere\" \"float3 radius\" 1", 2, 16, "unknown parameter type 'float3'");
    check("WorldBegin\nShape \"sphere\" \"radius\" 1", 2, 16, "type and a name");
    check("WorldBegin\nShape \"m\" \"point3 P\" [ 0 0 0 1 ]", 2, 11, "multiple of 3");
}

#[test]
fn unknown_named_material() {
    check("WorldBegin\nNamedMaterial \"gold\"\nShape \"sphere\"", 2, 15, "'gold'");
    check("WorldBegin\nObjectInstance \"nothing\"", 2, 1, "'nothing'");
    check("WorldBegin\nMediumInterface \"fog\" \"\"\nShape \"sphere\"", 2, 1, "'fog'");
    check("WorldBegin\nMaterial \"diffuse\"\n \"texture reflectance\" \"nope\"", 3, 2, "'nope'");
}

#[test]
fn odd_inline_spectrum() {
    check("WorldBegin\nMaterial \"conductor\" \"spectrum eta\" [ 400 1.5 500 ]", 2, 22, "odd");
    check("WorldBegin\nMaterial \"conductor\" \"spectrum eta\" [ 500 1.5 400 1.4 ]", 2, 22, "increase");
    check("WorldBegin\nMaterial \"conductor\" \"spectrum eta\" \"no-such-thing\"", 2, 37, "neither a named spectrum");
    check("WorldBegin\nMaterial \"conductor\" \"spectrum eta\" [ 400 1 \"x\" ]", 2, 45, "expects numbers");
}

#[test]
fn non_finite_value() {
    check("WorldBegin\nShape \"sphere\" \"float radius\" 1e999", 2, 31, "not finite");
    check("WorldBegin\nShape \"sphere\" \"float radius\" inf", 2, 31, "'inf'");
    check("WorldBegin\nShape \"sphere\" \"float radius\" nan", 2, 31, "'nan'");
}

#[test]
fn unknown_color_space() {
    check("ColorSpace \"adobe-rgb\"\nWorldBegin", 1, 12, "only \"srgb\"");
}

#[test]
fn world_begin_twice_and_misplaced_directives() {
    check("WorldBegin\n  WorldBegin", 2, 3, "WorldBegin given twice (first at dir/bad.pbrt:1:1)");
    check("Shape \"sphere\"\nWorldBegin", 1, 1, "only allowed after WorldBegin");
    check("WorldBegin\nFilm \"rgb\"", 2, 1, "not allowed after WorldBegin");
    check("Film \"rgb\"", 1, 6, "end of input before WorldBegin");
    check("WorldBegin\nObjectBegin \"a\"\nObjectBegin \"b\"", 3, 1, "inside the definition");
    check("WorldBegin\nObjectBegin \"a\" ObjectEnd ObjectBegin \"a\"", 2, 27, "defined again");
    check("WorldBegin\nMakeNamedMaterial \"m\" \"float x\" 1", 2, 1, "\"string type\"");
    check("WorldBegin\nAttribute \"camera\" \"float x\" 1", 2, 11, "unknown Attribute target");
    check("WorldBegin\nTexture \"t\" \"colour\" \"imagemap\"", 2, 13, "unknown texture type");
    check("Scale 1 0 1\n  Camera \"perspective\"\nWorldBegin", 2, 3, "camera transform is singular");
    check("LookAt 0 0 0 0 0 0 0 1 0\nWorldBegin", 1, 1, "degenerate");
    check("Camera perspective\nWorldBegin", 1, 8, "quoted string");
    check("WorldBegin\nShape \"sphere\" \"string s\" \"a\\qb\"", 2, 29, "unknown escape");
}

#[test]
fn include_cycle() {
    let dir = temp_dir("cycle");
    std::fs::write(dir.join("main.pbrt"), "WorldBegin\nInclude \"a.pbrt\"\n").unwrap();
    std::fs::write(dir.join("a.pbrt"), "Shape \"sphere\"\n  Include \"main.pbrt\"\n").unwrap();
    let e = pbrt::parse_file(&dir.join("main.pbrt")).unwrap_err();
    assert!(e.loc.file.ends_with("a.pbrt"), "{e}");
    assert_eq!((e.loc.line, e.loc.column), (2, 3));
    assert!(e.message.contains("cycle"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn errors_in_included_files_name_that_file_and_the_chain() {
    let dir = temp_dir("chain");
    std::fs::create_dir_all(dir.join("geo")).unwrap();
    std::fs::write(dir.join("main.pbrt"), "WorldBegin\n\nInclude \"geo/mesh.pbrt\"\n").unwrap();
    std::fs::write(dir.join("geo/mesh.pbrt"), "Shape \"trianglemesh\"\n  \"point3 P\" [ 0 0 zero ]\n").unwrap();
    let e = pbrt::parse_file(&dir.join("main.pbrt")).unwrap_err();
    assert!(e.loc.file.ends_with("geo/mesh.pbrt"), "{e}");
    assert_eq!((e.loc.line, e.loc.column), (2, 20));
    assert_eq!(e.included_from.len(), 1);
    assert!(e.included_from[0].file.ends_with("main.pbrt"));
    assert_eq!(e.included_from[0].line, 3);
    let shown = e.to_string();
    assert!(shown.contains("main.pbrt:3:1: note: included from here"), "{shown}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_spectrum_files() {
    let dir = temp_dir("spd");
    std::fs::write(dir.join("odd.spd"), "400 1\n500\n").unwrap();
    std::fs::write(dir.join("junk.spd"), "400 1\n500 abc\n").unwrap();
    let scene = dir.join("s.pbrt");
    let e = pbrt::parse_str("WorldBegin\nMaterial \"conductor\" \"spectrum k\" \"odd.spd\"", &scene).unwrap_err();
    assert_eq!((e.loc.line, e.loc.column), (2, 35), "{e}");
    assert!(e.message.contains("odd"), "{e}");
    let e = pbrt::parse_str("WorldBegin\nMaterial \"conductor\" \"spectrum k\" \"junk.spd\"", &scene).unwrap_err();
    assert_eq!((e.loc.line, e.loc.column), (2, 35), "{e}");
    assert!(e.message.contains("junk.spd:2:5") && e.message.contains("'abc'"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

fn gzip(data: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(data).unwrap();
    e.finish().unwrap()
}

#[test]
fn gzip_scene_errors_name_the_line_in_the_decompressed_text() {
    let dir = temp_dir("gzerr");
    std::fs::write(dir.join("bad.pbrt.gz"), gzip(b"WorldBegin\n# fine\n  Shape \"sphere\" \"float radius\" [ x ]\n"))
        .unwrap();
    let e = pbrt::parse_file(&dir.join("bad.pbrt.gz")).unwrap_err();
    assert!(e.to_string().contains("bad.pbrt.gz:3:35: error: "), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn non_utf8_and_gzip_files() {
    let dir = temp_dir("enc");
    std::fs::write(dir.join("latin1.pbrt"), b"WorldBegin\n# caf\xe9\n").unwrap();
    let e = pbrt::parse_file(&dir.join("latin1.pbrt")).unwrap_err();
    assert_eq!((e.loc.line, e.loc.column), (2, 6), "{e}");
    // A truncated gzip file is an error at the file (or at the Include naming it), not a panic.
    let z = gzip(b"WorldBegin\nShape \"sphere\"\n");
    std::fs::write(dir.join("cut.pbrt.gz"), &z[..z.len() - 6]).unwrap();
    let e = pbrt::parse_file(&dir.join("cut.pbrt.gz")).unwrap_err();
    assert_eq!((e.loc.line, e.loc.column), (1, 1), "{e}");
    assert!(e.message.contains("corrupt or truncated gzip"), "{e}");
    std::fs::write(dir.join("main.pbrt"), "WorldBegin\n  Include \"cut.pbrt.gz\"\n").unwrap();
    let e = pbrt::parse_file(&dir.join("main.pbrt")).unwrap_err();
    assert!(e.loc.file.ends_with("main.pbrt") && (e.loc.line, e.loc.column) == (2, 3), "{e}");
    assert!(e.message.contains("gzip"), "{e}");
    let e = pbrt::parse_file(&dir.join("absent.pbrt")).unwrap_err();
    assert!(e.message.contains("cannot read"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}
