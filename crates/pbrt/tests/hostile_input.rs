//! Bytes as a file would hold them ([`pbrt::parse_bytes`]), and inputs the fuzzer found (docs/robustness.md):
//! each must give an error (or a scene), never a panic, a hang or an unbounded allocation.

use std::io::Write;
use std::path::Path;

fn gzip(data: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(data).unwrap();
    e.finish().unwrap()
}

#[test]
fn bytes_are_read_as_a_file_would_be() {
    let text = b"WorldBegin\n  Shape \"sphere\" \"float radius\" 2\nShape \"disk\"\n";
    let path = Path::new("/nowhere/s.pbrt");
    for bytes in [text.to_vec(), gzip(text)] {
        let s = pbrt::parse_bytes(&bytes, path).unwrap_or_else(|e| panic!("{e}"));
        let names: Vec<_> = s.shapes.iter().map(|s| s.entity.name.as_str()).collect();
        assert_eq!(names, ["sphere", "disk"]);
        assert_eq!(s.shapes[0].entity.params.get_float("radius", 1.0).unwrap(), 2.0);
        let l = &s.shapes[0].entity.loc;
        assert_eq!((l.file.as_ref(), l.line, l.column), (path, 2, 3));
    }
    // Invalid UTF-8 is reported where it starts; UTF-16 is named; a cut gzip stream is an error.
    let e = pbrt::parse_bytes(b"WorldBegin\nShape \xff", path).unwrap_err();
    assert_eq!((e.loc.line, e.loc.column), (2, 7), "{e}");
    assert!(e.message.contains("not valid UTF-8"), "{e}");
    let e = pbrt::parse_bytes(&[0xff, 0xfe, b'W', 0], path).unwrap_err();
    assert!(e.message.contains("UTF-16"), "{e}");
    let z = gzip(text);
    let e = pbrt::parse_bytes(&z[..z.len() / 2], path).unwrap_err();
    assert!(e.message.contains("corrupt or truncated gzip"), "{e}");
}
