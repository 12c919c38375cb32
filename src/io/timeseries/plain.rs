//! The fast path of the block reader: a line of plain numbers between
//! single separators, parsed in one pass from the block's bytes.
//!
//! Almost every line of a measured record is plain: no quotes, no spaces
//! around the fields, no comment. Such a line is read here without cutting
//! it into fields first: each wanted field is parsed where it starts
//! (`fast-float2` reports how many bytes the number took, so the byte after
//! it must be the separator or the line end) and each unwanted field is
//! skipped to the next separator. Any line that is not plain (or holds a
//! value the general path would refuse) is left to the general path, which
//! reads it the same way or names what is wrong with it, so the fast path
//! changes no value and no message.

use super::rows::Delimiter;

/// Where each field of a plain line goes.
pub(super) struct PlainLine {
    separator: u8,
    /// By field index up to the last wanted one: the slot of the value, or
    /// `None` for a field that is skipped.
    slots: Vec<Option<usize>>,
}

impl PlainLine {
    /// The fast path for values `slot = 0, 1, ...` read from the 0-based
    /// `fields`; `None` for whitespace-separated text or a field wanted
    /// twice (the general path reads those).
    pub(super) fn new(delimiter: Delimiter, fields: &[usize]) -> Option<Self> {
        let separator = match delimiter {
            Delimiter::Comma => b',',
            Delimiter::Semicolon => b';',
            Delimiter::Tab => b'\t',
            Delimiter::Whitespace => return None,
        };
        let mut slots = vec![None; fields.iter().max()? + 1];
        for (slot, &field) in fields.iter().enumerate() {
            if slots[field].replace(slot).is_some() {
                return None;
            }
        }
        Some(Self { separator, slots })
    }

    /// Reads the line at the start of `text` into `values`: the length of
    /// the line with its line end, or `None` when the line is not plain
    /// (`values` may then hold some of its fields).
    pub(super) fn parse(&self, text: &[u8], values: &mut [f64]) -> Option<usize> {
        // A comment, a blank line or a field with leading space: general path.
        if matches!(
            text.first(),
            None | Some(b'#' | b' ' | b'\t' | b'\r' | b'\n')
        ) {
            return None;
        }
        let last = self.slots.len() - 1;
        let mut pos = 0;
        for (field, slot) in self.slots.iter().enumerate() {
            let rest = &text[pos..];
            pos += match slot {
                Some(slot) => {
                    let (value, used) = fast_float2::parse_partial::<f64, _>(rest).ok()?;
                    if !value.is_finite() {
                        return None;
                    }
                    values[*slot] = value;
                    used
                }
                // A quote may hide a separator: general path.
                None => match memchr::memchr3(self.separator, b'\n', b'"', rest) {
                    Some(i) if rest[i] == self.separator => i,
                    _ => return None,
                },
            };
            if field < last {
                if text.get(pos) != Some(&self.separator) {
                    return None;
                }
                pos += 1;
            }
        }
        self.line_end(text, pos)
    }

    /// The end of the line whose wanted fields end at `pos`.
    fn line_end(&self, text: &[u8], pos: usize) -> Option<usize> {
        match text.get(pos) {
            None => Some(pos),
            Some(b'\n') => Some(pos + 1),
            Some(b'\r') if text.get(pos + 1) == Some(&b'\n') => Some(pos + 2),
            // Fields past the last one wanted are not read, unless a quote
            // among them makes the line one csv-core must check.
            Some(&b) if b == self.separator => {
                let rest = &text[pos..];
                match memchr::memchr2(b'\n', b'"', rest) {
                    None => Some(text.len()),
                    Some(i) if rest[i] == b'\n' => Some(pos + i + 1),
                    Some(_) => None,
                }
            }
            Some(_) => None,
        }
    }
}
