//! VTK XML `<DataArray>` elements, the one building block of `.vtu` and `.vti` files: typed
//! values written inline either as ASCII or as base64 "binary" (VTK's inline binary: a UInt64
//! byte count followed by the little-endian values, base64-encoded as one stream; files declare
//! `header_type="UInt64"` and `byte_order="LittleEndian"`). Both are exact: ASCII floats are
//! printed in Rust's shortest round-trip form.

use std::fmt::Write;

/// How arrays are written.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Encoding {
    /// Inline base64 of the raw little-endian values (about 1.4 bytes per byte of data).
    #[default]
    Base64,
    /// Inline text, readable by eye (two to three times larger than base64).
    Ascii,
}

/// Typed values of one array.
#[derive(Clone, Copy, Debug)]
pub enum Values<'a> {
    F64(&'a [f64]),
    I64(&'a [i64]),
    U32(&'a [u32]),
    U8(&'a [u8]),
}

impl Values<'_> {
    fn vtk_type(&self) -> &'static str {
        match self {
            Values::F64(_) => "Float64",
            Values::I64(_) => "Int64",
            Values::U32(_) => "UInt32",
            Values::U8(_) => "UInt8",
        }
    }

    fn len(&self) -> usize {
        match self {
            Values::F64(v) => v.len(),
            Values::I64(v) => v.len(),
            Values::U32(v) => v.len(),
            Values::U8(v) => v.len(),
        }
    }

    fn le_bytes(&self) -> Vec<u8> {
        match self {
            Values::F64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::I64(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::U32(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            Values::U8(v) => v.to_vec(),
        }
    }

    fn write_ascii(&self, out: &mut String) {
        fn join<T>(out: &mut String, v: &[T], f: impl Fn(&mut String, &T)) {
            for (k, x) in v.iter().enumerate() {
                if k > 0 {
                    out.push(if k % 9 == 0 { '\n' } else { ' ' });
                }
                f(out, x);
            }
        }
        match self {
            // `{:e}` is the shortest form that parses back to the same f64, in a notation C++
            // streams read.
            Values::F64(v) => join(out, v, |o, x| write!(o, "{x:e}").expect("string")),
            Values::I64(v) => join(out, v, |o, x| write!(o, "{x}").expect("string")),
            Values::U32(v) => join(out, v, |o, x| write!(o, "{x}").expect("string")),
            Values::U8(v) => join(out, v, |o, x| write!(o, "{x}").expect("string")),
        }
    }
}

/// Appends `<DataArray type=".." Name=".." NumberOfComponents=".." format="..">…</DataArray>`.
pub fn write_data_array(
    out: &mut String,
    indent: &str,
    name: &str,
    components: usize,
    values: Values<'_>,
    encoding: Encoding,
) {
    let format = match encoding {
        Encoding::Base64 => "binary",
        Encoding::Ascii => "ascii",
    };
    // NumberOfTuples is what VTK sizes `FieldData` arrays by (point arrays take the points').
    let tuples = values.len() / components.max(1);
    writeln!(
        out,
        "{indent}<DataArray type=\"{}\" Name=\"{}\" NumberOfComponents=\"{components}\" NumberOfTuples=\"{tuples}\" format=\"{format}\">",
        values.vtk_type(),
        escape(name)
    )
    .expect("string");
    out.push_str(indent);
    out.push_str("  ");
    match encoding {
        Encoding::Base64 => {
            let data = values.le_bytes();
            let mut raw = Vec::with_capacity(8 + data.len());
            raw.extend_from_slice(&(data.len() as u64).to_le_bytes());
            raw.extend_from_slice(&data);
            out.push_str(&base64(&raw));
        }
        Encoding::Ascii => values.write_ascii(out),
    }
    out.push('\n');
    writeln!(out, "{indent}</DataArray>").expect("string");
}

/// The opening line of a VTK XML file of dataset `kind` (`UnstructuredGrid`, `ImageData`,
/// `Collection`).
pub fn vtk_file_open(kind: &str) -> String {
    format!(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"{kind}\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">\n"
    )
}

/// Escapes text for an XML attribute value.
pub fn escape(s: &str) -> String {
    let mut o = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => o.push_str("&amp;"),
            '<' => o.push_str("&lt;"),
            '>' => o.push_str("&gt;"),
            '"' => o.push_str("&quot;"),
            '\'' => o.push_str("&apos;"),
            c => o.push(c),
        }
    }
    o
}

/// Standard base64 (RFC 4648, with padding), as VTK reads it.
pub fn base64(bytes: &[u8]) -> String {
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut o = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for c in bytes.chunks(3) {
        let b = [c[0], *c.get(1).unwrap_or(&0), *c.get(2).unwrap_or(&0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= c.len() {
                o.push(ABC[((n >> (18 - 6 * k)) & 63) as usize] as char);
            } else {
                o.push('=');
            }
        }
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_matches_rfc4648_vectors() {
        for (plain, coded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(base64(plain.as_bytes()), coded);
        }
        assert_eq!(base64(&[0xff, 0xfe, 0xfd]), "//79");
    }

    #[test]
    fn ascii_floats_round_trip_exactly() {
        let v = [0.1, -1e-300, 1.0 / 3.0, 6.02214076e23, 0.0];
        let mut s = String::new();
        Values::F64(&v).write_ascii(&mut s);
        let back: Vec<f64> = s.split_whitespace().map(|t| t.parse().unwrap()).collect();
        assert_eq!(back, v);
    }

    #[test]
    fn names_are_escaped() {
        let mut s = String::new();
        write_data_array(
            &mut s,
            "",
            "a<b & \"c\"",
            1,
            Values::U8(&[1]),
            Encoding::Ascii,
        );
        assert!(s.contains("Name=\"a&lt;b &amp; &quot;c&quot;\""), "{s}");
    }
}
