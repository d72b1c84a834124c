//! Files of other formats given where a scene goes: recognised by their first bytes or their first
//! line, so that the reader says what the file is instead of skipping its lines as unknown tags.

/// The format of `text` if its first line (after blank and comment lines) is that of another 3D
/// format than p3f and NFF: its name with an article, for the message, the line and column it was
/// recognised at, and what to do instead.
pub(crate) fn foreign_format(text: &str) -> Option<(&'static str, u32, u32, &'static str)> {
    const NOT_READ: &str = "raylume reads p3f and NFF scenes, and OBJ meshes";
    const AS_MESH: &str = "load it as a mesh: `raylume render --mesh FILE`, or `obj::load`";
    // Signatures that sit on the first bytes, comment-like or binary.
    let starts = [
        ("#usda", "a USD scene"),
        ("glTF", "a binary glTF scene"),
        ("Kaydara FBX Binary", "an FBX scene"),
        ("<?xml", "an XML document"),
    ];
    if let Some((_, name)) = starts.iter().find(|(magic, _)| text.starts_with(magic)) {
        return Some((name, 1, 1, NOT_READ));
    }
    let (index, line) =
        text.lines().enumerate().find(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'))?;
    let column = (line.chars().count() - line.trim_start().chars().count()) as u32 + 1;
    let at = |name, then| Some((name, index as u32 + 1, column, then));
    let mut words = line.split_whitespace();
    let first = words.next()?;
    let is_number = |w: Option<&str>| w.is_some_and(|w| w.parse::<f64>().is_ok());
    match first {
        "ply" => at("a PLY mesh", NOT_READ),
        "solid" if text.contains("facet") => at("an STL mesh", NOT_READ),
        // OBJ's own tags; a `v` of three numbers is a vertex, where p3f's `v` starts the view.
        "mtllib" | "usemtl" | "vn" | "vt" | "o" => at("a Wavefront OBJ mesh", AS_MESH),
        "v" if is_number(words.next()) => at("a Wavefront OBJ mesh", AS_MESH),
        // pbrt's directives are capitalised; p3f's and NFF's tags are not.
        "LookAt" | "Camera" | "Film" | "Sampler" | "Integrator" | "WorldBegin" | "Shape" | "Include" | "Import"
        | "Option" | "ColorSpace" | "PixelFilter" | "Translate" | "Scale" | "Rotate" | "Transform" => {
            at("a pbrt scene", NOT_READ)
        }
        _ if first.starts_with('{') => at("a JSON document (a glTF scene?)", NOT_READ),
        _ if first.starts_with('<') => at("an XML document", NOT_READ),
        _ => None,
    }
}

/// What a file that is not text holds, told by its first bytes: the images raylume writes and
/// reads, compressed data, a binary glTF scene, or any other bytes with a control character (not
/// whitespace) among their first 16, which text never has; `None` for text, UTF-16 text included.
pub(crate) fn binary_kind(bytes: &[u8]) -> Option<String> {
    const SIGNATURES: [(&[u8], &str); 6] = [
        (b"\x89PNG", "a PNG image"),
        (b"\xFF\xD8\xFF", "a JPEG image"),
        (b"\x76\x2F\x31\x01", "an OpenEXR image"),
        (b"\x1F\x8B", "gzip-compressed data (decompress it first)"),
        (b"PK\x03\x04", "a zip archive (extract the scene first)"),
        (b"glTF", "a binary glTF scene"),
    ];
    if let Some((_, kind)) = SIGNATURES.iter().find(|(magic, _)| bytes.starts_with(magic)) {
        return Some((*kind).to_owned());
    }
    if super::utf16_order(bytes).is_some() {
        return None;
    }
    let head = &bytes[..bytes.len().min(16)];
    head.iter()
        .find(|&&b| b.is_ascii_control() && !b.is_ascii_whitespace())
        .map(|b| format!("binary data (byte 0x{b:02X}, a control character, in its first 16 bytes)"))
}

#[cfg(test)]
mod tests {
    use super::foreign_format;

    #[test]
    fn other_formats_are_named_at_their_first_line() {
        let cases = [
            ("ply\nformat ascii 1.0\n", "a PLY mesh", 1, 1),
            ("solid cube\n  facet normal 0 0 1\n", "an STL mesh", 1, 1),
            ("# Blender OBJ\n\nv 0.5 1 2\nf 1 2 3\n", "a Wavefront OBJ mesh", 3, 1),
            ("mtllib a.mtl\n", "a Wavefront OBJ mesh", 1, 1),
            ("  vn 0 0 1\n", "a Wavefront OBJ mesh", 1, 3),
            ("LookAt 0 0 5  0 0 0  0 1 0\nCamera \"perspective\"\n", "a pbrt scene", 1, 1),
            ("{\n \"asset\": {\"version\": \"2.0\"}\n}\n", "a JSON document (a glTF scene?)", 1, 1),
            ("<?xml version=\"1.0\"?>\n<scene version=\"3.0.0\">\n", "an XML document", 1, 1),
            ("glTF\u{2}\u{0}\u{0}\u{0}", "a binary glTF scene", 1, 1),
            ("#usda 1.0\n", "a USD scene", 1, 1),
        ];
        for (text, name, line, column) in cases {
            let found = foreign_format(text).map(|(n, l, c, _)| (n, l, c));
            assert_eq!(found, Some((name, line, column)), "{text:?}");
        }
    }

    #[test]
    fn scenes_of_every_dialect_are_not_taken_for_other_formats() {
        let scenes = [
            "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 45\nhither 1\nresolution 8 8\n",
            "# a comment\nv from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 1 resolution 8 8\n",
            "b 0.1 0.2 0.3\nv\n",
            "bclr 0 0 0\nl 1 1 1\nf 1 0 0 1 0 0 0 0\ns 0 0 0 1\n",
            "solid_color 1 1 1\n",
            "",
            "# only comments\n",
        ];
        for text in scenes {
            assert_eq!(foreign_format(text), None, "{text:?}");
        }
    }
}
