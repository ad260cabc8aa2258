//! PLY reader (ascii, binary little and big endian) on top of `ply-rs-bw`.
//!
//! Why `ply-rs-bw` (v4) rather than a hand-written parser: it reads all three
//! encodings and every PLY scalar type, reports malformed data as errors with a
//! line (ascii) or element position (binary) instead of panicking, and caps
//! the capacity it reserves from header counts (65 536 items), so a header that
//! announces 4e9 vertices fails at the end of the real data instead of
//! allocating 4e9 slots. On top of that, binary files are checked against
//! their size before any element is read (each element needs at least the
//! bytes of its scalars and list counts), and binary elements without
//! properties are skipped, not iterated. We read through small custom element types
//! ([`PlyVertex`], [`PlyFace`]) rather than its hash-map elements, and every
//! error it returns is wrapped to name the file and the element being read.
//!
//! Accepted: element `vertex` with scalar properties `x`, `y`, `z` of any type
//! (float and double in practice); element `face` with an integer list
//! `vertex_indices` or `vertex_index` (any integer count and index types);
//! every other property and element is skipped. Polygons are
//! fan-triangulated; a negative index or a face with fewer than three corners
//! is an error; an index beyond the vertex count is kept for the defect report.

use std::path::Path;

use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{
    DefaultElement, Encoding, Header, Property, PropertyAccess, PropertyAccessResult, PropertyType,
    ScalarType,
};

use super::text::{capped, fan};
use crate::mesh::RawMesh;
use crate::{Error, Point, Result};

/// One vertex as read: coordinates and which of x, y, z were present.
#[derive(Default)]
struct PlyVertex {
    xyz: [f64; 3],
}

fn scalar_f64(p: &Property) -> Option<f64> {
    Some(match *p {
        Property::Char(v) => v as f64,
        Property::UChar(v) => v as f64,
        Property::Short(v) => v as f64,
        Property::UShort(v) => v as f64,
        Property::Int(v) => v as f64,
        Property::UInt(v) => v as f64,
        Property::Float(v) => v as f64,
        Property::Double(v) => v,
        _ => return None,
    })
}

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: &str, p: Property) -> PropertyAccessResult {
        let k = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            _ => return PropertyAccessResult::Ignored,
        };
        match scalar_f64(&p) {
            Some(v) => {
                self.xyz[k] = v;
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::UnsupportedType,
        }
    }
}

/// One face as read: its corner indices (signed, to detect negatives).
#[derive(Default)]
struct PlyFace {
    indices: Vec<i64>,
}

fn is_index_list_name(name: &str) -> bool {
    name == "vertex_indices" || name == "vertex_index"
}

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        Self::default()
    }
    fn set_property(&mut self, name: &str, p: Property) -> PropertyAccessResult {
        if !is_index_list_name(name) {
            return PropertyAccessResult::Ignored;
        }
        self.indices = match p {
            Property::ListChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUChar(v) => v.into_iter().map(i64::from).collect(),
            Property::ListShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUShort(v) => v.into_iter().map(i64::from).collect(),
            Property::ListInt(v) => v.into_iter().map(i64::from).collect(),
            Property::ListUInt(v) => v.into_iter().map(i64::from).collect(),
            _ => return PropertyAccessResult::UnsupportedType,
        };
        PropertyAccessResult::Set
    }
}

/// An element we do not use: every property is read and dropped.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

fn is_integer(t: &ScalarType) -> bool {
    !matches!(t, ScalarType::Float | ScalarType::Double)
}

fn scalar_size(t: &ScalarType) -> u64 {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// Binary encodings: checks that the file is large enough for the element
/// counts of its header, each element taking at least the bytes of its
/// scalars and list counts. A header announcing 4e9 vertices in a small
/// file is refused before any element is read (the reader would otherwise
/// loop over, and collect, elements that cannot exist; elements without
/// properties would make it spin through the whole announced count).
fn check_binary_sizes(path: &Path, header: &Header, file_len: usize) -> Result<()> {
    if header.encoding == Encoding::Ascii {
        return Ok(()); // every element is a line: reading stops at the end of the file
    }
    let mut total: u64 = 0;
    for def in header.elements.values() {
        let size: u64 = def
            .properties
            .values()
            .map(|p| match &p.data_type {
                PropertyType::Scalar(t) => scalar_size(t),
                PropertyType::List(count, _) => scalar_size(count),
            })
            .sum();
        let need = (def.count as u64).saturating_mul(size);
        total = total.saturating_add(need);
        if total > file_len as u64 {
            return Err(Error::parse(
                path,
                "header",
                format!(
                    "element '{}' announces {} items of at least {size} bytes each, but the \
                     file has only {file_len} bytes",
                    def.name, def.count
                ),
            ));
        }
    }
    Ok(())
}

/// A property declared twice in one element is refused, naming both
/// lines: the header parser keeps one of the two, so the values of a row
/// would be read under the wrong names (a second `z` flattens the mesh).
/// Elements declared twice are refused the same way.
fn check_unique_properties(path: &Path, bytes: &[u8]) -> Result<()> {
    let head = &bytes[..bytes.len().min(1 << 16)];
    let text = String::from_utf8_lossy(head);
    let mut elements: Vec<(String, usize)> = Vec::new();
    let mut seen: Vec<(String, usize)> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("end_header") => break,
            Some("element") => {
                let name = words.next().unwrap_or("").to_string();
                if let Some((_, first)) = elements.iter().find(|(n, _)| *n == name) {
                    return Err(Error::parse(
                        path,
                        "header",
                        format!(
                            "element '{name}' is declared twice (lines {} and {})",
                            first,
                            i + 1
                        ),
                    ));
                }
                elements.push((name, i + 1));
                seen.clear();
            }
            Some("property") => {
                // `property TYPE NAME` or `property list COUNT INDEX NAME`.
                let Some(name) = line.split_whitespace().last() else {
                    continue;
                };
                if let Some((_, first)) = seen.iter().find(|(n, _)| n == name) {
                    let element = elements.last().map_or("", |(n, _)| n.as_str());
                    return Err(Error::parse(
                        path,
                        "header",
                        format!(
                            "property '{name}' of element '{element}' is declared twice \
                             (lines {first} and {}); its values cannot be told apart",
                            i + 1
                        ),
                    ));
                }
                seen.push((name.to_string(), i + 1));
            }
            _ => {}
        }
    }
    Ok(())
}

/// What is wrong with the data line an ASCII parse error points at
/// (`ply-rs-bw` says "Line 14: Couldn't read element line" and quotes its
/// grammar): the place (`element 'vertex' item 4 (line 14)`) and the first value that is
/// not a number, or not a finite one, or a count of values that does not
/// match the header. `None` when the message names no line or the line
/// shows nothing wrong.
fn explain_ascii_line(bytes: &[u8], header: &Header, message: &str) -> Option<(String, String)> {
    if header.encoding != Encoding::Ascii {
        return None;
    }
    let n: usize = message
        .strip_prefix("Line ")?
        .split(':')
        .next()?
        .trim()
        .parse()
        .ok()?;
    let text = String::from_utf8_lossy(bytes);
    let mut lines = text.lines();
    let header_lines = lines.by_ref().position(|l| l.trim() == "end_header")? + 1;
    let line = text.lines().nth(n.checked_sub(1)?)?;
    // Which element and item the line holds.
    let mut item = n.checked_sub(header_lines + 1)?;
    let mut element = None;
    for def in header.elements.values() {
        if item < def.count {
            element = Some(def);
            break;
        }
        item -= def.count;
    }
    let def = element?;
    let place = format!("element '{}' item {item} (line {n})", def.name);
    let words: Vec<&str> = line.split_whitespace().collect();
    for w in &words {
        match w.parse::<f64>() {
            Err(_) => return Some((place, format!("'{w}' is not a number"))),
            Ok(v) if !v.is_finite() => {
                return Some((place, format!("'{w}' is not a finite number")))
            }
            Ok(_) => {}
        }
    }
    let scalars = def
        .properties
        .values()
        .all(|p| matches!(p.data_type, PropertyType::Scalar(_)));
    if scalars && words.len() != def.properties.len() {
        return Some((
            place,
            format!(
                "{} values, but the header declares {} properties for '{}'",
                words.len(),
                def.properties.len(),
                def.name
            ),
        ));
    }
    None
}

/// `ply-rs-bw` says "Line 3: Couldn't parse line."; append the text of that
/// header line so the user sees what was wrong.
fn quote_header_line(bytes: &[u8], message: &str) -> String {
    let line_no = message
        .strip_prefix("Line ")
        .and_then(|r| r.split(':').next())
        .and_then(|n| n.trim().parse::<usize>().ok());
    let Some(n) = line_no.filter(|&n| n >= 1) else {
        return tidy(message);
    };
    let head = &bytes[..bytes.len().min(1 << 16)];
    let text = String::from_utf8_lossy(head);
    match text.lines().nth(n - 1) {
        Some(l) => {
            let l: String = l.chars().take(80).collect();
            let first = message.lines().next().unwrap_or(message);
            format!("{first} (the line reads '{l}')")
        }
        None => tidy(message),
    }
}

/// `ply-rs-bw` messages span several lines, some holding parser internals;
/// keep the informative lines and join them into one.
fn tidy(message: &str) -> String {
    message
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && *l != "'" && !l.contains("ParseError {"))
        .filter(|l| !l.starts_with("Error: failed to fill whole buffer"))
        .collect::<Vec<_>>()
        .join("; ")
}

pub(super) fn read_ply(path: &Path) -> Result<RawMesh> {
    let bytes = super::read_input_file(path)?;
    parse_ply(path, super::text::strip_bom(&bytes))
}

/// Parses the bytes of a PLY file; `path` only names it in messages.
pub(super) fn parse_ply(path: &Path, bytes: &[u8]) -> Result<RawMesh> {
    let mut reader = Reader::new(bytes);
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(|e| Error::parse(path, "header", quote_header_line(bytes, &e.to_string())))?;

    // Check the header before reading any data.
    check_unique_properties(path, bytes)?;
    let vdef = header
        .elements
        .get("vertex")
        .ok_or_else(|| Error::parse(path, "header", "no 'vertex' element declared"))?;
    for c in ["x", "y", "z"] {
        match vdef.properties.get(c).map(|p| &p.data_type) {
            Some(PropertyType::Scalar(_)) => {}
            Some(PropertyType::List(..)) => {
                return Err(Error::parse(
                    path,
                    "header",
                    format!("vertex property '{c}' is a list, expected a number"),
                ))
            }
            None => {
                return Err(Error::parse(
                    path,
                    "header",
                    format!("vertex element has no '{c}' property"),
                ))
            }
        }
    }
    if let Some(fdef) = header.elements.get("face") {
        let list = fdef
            .properties
            .values()
            .find(|p| is_index_list_name(&p.name))
            .ok_or_else(|| {
                Error::parse(
                    path,
                    "header",
                    "face element has no 'vertex_indices' or 'vertex_index' property",
                )
            })?;
        match &list.data_type {
            PropertyType::List(count, index) if is_integer(count) && is_integer(index) => {}
            other => {
                return Err(Error::parse(
                    path,
                    "header",
                    format!(
                        "face property '{}' must be a list of integers with an integer count, \
                         declared as {other:?}",
                        list.name
                    ),
                ))
            }
        }
    }

    check_binary_sizes(path, &header, bytes.len())?;

    let mut raw = RawMesh::default();
    for def in header.elements.values() {
        if def.properties.is_empty() && header.encoding != Encoding::Ascii {
            continue; // no bytes to read, however many items are announced
        }
        let wrap = |e: ply_rs_bw::parser::ParseError| {
            let message = e.to_string();
            match explain_ascii_line(bytes, &header, &message) {
                Some((place, why)) => Error::parse(path, place, why),
                None => Error::parse(path, format!("element '{}'", def.name), tidy(&message)),
            }
        };
        match def.name.as_str() {
            "vertex" => {
                let vs = Parser::<PlyVertex>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(wrap)?;
                raw.vertices = vs
                    .into_iter()
                    .map(|v| Point::new(v.xyz[0], v.xyz[1], v.xyz[2]))
                    .collect();
            }
            "face" => {
                let fs = Parser::<PlyFace>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(wrap)?;
                raw.faces = Vec::with_capacity(capped(fs.len()));
                let mut polygon = Vec::new();
                for (i, f) in fs.iter().enumerate() {
                    if f.indices.len() < 3 {
                        return Err(Error::parse(
                            path,
                            format!("face {i}"),
                            format!("{} corners; at least 3 are needed", f.indices.len()),
                        ));
                    }
                    polygon.clear();
                    for &k in &f.indices {
                        let k = usize::try_from(k).map_err(|_| {
                            Error::parse(path, format!("face {i}"), format!("negative index {k}"))
                        })?;
                        polygon.push(k);
                    }
                    fan(&polygon, &mut raw.faces);
                }
            }
            _ => {
                Parser::<Skip>::new()
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(wrap)?;
            }
        }
    }
    Ok(raw)
}

/// The vertex property `name` of a PLY file's bytes (`None` when the
/// vertex element has none); a list property is an error. `path` names the
/// file in messages.
pub(super) fn parse_vertex_scalar(
    path: &Path,
    bytes: &[u8],
    name: &str,
) -> Result<Option<Vec<f64>>> {
    let mut reader = Reader::new(bytes);
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(|e| Error::parse(path, "header", quote_header_line(bytes, &e.to_string())))?;
    check_unique_properties(path, bytes)?;
    let vdef = header
        .elements
        .get("vertex")
        .ok_or_else(|| Error::parse(path, "header", "no 'vertex' element declared"))?;
    match vdef.properties.get(name).map(|p| &p.data_type) {
        None => return Ok(None),
        Some(PropertyType::List(..)) => {
            return Err(Error::parse(
                path,
                "header",
                format!("vertex property '{name}' is a list, expected a number"),
            ))
        }
        Some(PropertyType::Scalar(_)) => {}
    }
    check_binary_sizes(path, &header, bytes.len())?;
    for def in header.elements.values() {
        if def.properties.is_empty() && header.encoding != Encoding::Ascii {
            continue;
        }
        let wrap = |e: ply_rs_bw::parser::ParseError| {
            let message = e.to_string();
            match explain_ascii_line(bytes, &header, &message) {
                Some((place, why)) => Error::parse(path, place, why),
                None => Error::parse(path, format!("element '{}'", def.name), tidy(&message)),
            }
        };
        if def.name == "vertex" {
            let vs = Parser::<DefaultElement>::new()
                .read_payload_for_element(&mut reader, def, &header)
                .map_err(wrap)?;
            return vs
                .iter()
                .enumerate()
                .map(|(i, v)| {
                    v.get(name).and_then(scalar_f64).ok_or_else(|| {
                        Error::parse(path, format!("vertex {i}"), format!("no number '{name}'"))
                    })
                })
                .collect::<Result<Vec<f64>>>()
                .map(Some);
        }
        Parser::<Skip>::new()
            .read_payload_for_element(&mut reader, def, &header)
            .map_err(wrap)?;
    }
    Ok(None)
}
