//! Bytes made readable for logs, error messages and the traffic console.

use std::fmt::Write as _;

/// Render bytes so that every byte is visible and none acts on a terminal.
pub fn readable(bytes: &[u8]) -> String {
    let mut out = String::with_capacity(bytes.len() + 8);
    for &b in bytes {
        match b {
            b'\r' => out.push_str("<CR>"),
            b'\n' => out.push_str("<LF>"),
            0x1A => out.push_str("<EOF>"),
            b'<' => out.push_str("<3C>"),
            0x20..=0x7E => out.push(b as char),
            _ => {
                let _ = write!(out, "<{b:02X}>");
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn control_bytes_show_as_hex_and_text_as_text() {
        assert_eq!(readable(b"@0P\r"), "@0P<CR>");
        assert_eq!(readable(&[0xFD, 0xFF]), "<FD><FF>");
        assert_eq!(readable(b"0211110000000000\x1a"), "0211110000000000<EOF>");
        assert_eq!(readable(b"\x02\r"), "<02><CR>");
        // A literal `<` must not be confused with the start of a hex escape.
        assert_eq!(readable(b"a<b"), "a<3C>b");
    }
}
