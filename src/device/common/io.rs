//! Building the groups of an `IoSnapshot`: named bits read from the
//! controller, and outputs the operator may switch (with their `OutputId`).

use crate::device::api::{IoBit, IoGroup, OutputId};

/// A bit read from the controller (an input or a status flag).
pub fn input(name: impl Into<String>, value: bool) -> IoBit {
    IoBit {
        name: name.into(),
        value,
        output: None,
        hazardous: false,
    }
}

/// A switchable output.
pub fn output(name: impl Into<String>, value: bool, id: OutputId, hazardous: bool) -> IoBit {
    IoBit {
        name: name.into(),
        value,
        output: Some(id),
        hazardous,
    }
}

/// A group of bits; `raw` is the byte as read (or written), shown in hex.
/// Not marked as read from the controller: inputs add that with
/// `IoGroup::read_from`.
pub fn group(name: impl Into<String>, raw: Option<u8>, bits: Vec<IoBit>) -> IoGroup {
    IoGroup {
        name: name.into(),
        raw,
        bits,
        read: None,
    }
}

/// The bits of `raw`, bit 0 first, named by `names`.
pub fn inputs_of(raw: u8, names: &[&str]) -> Vec<IoBit> {
    names
        .iter()
        .enumerate()
        .map(|(i, name)| input(*name, raw & (1 << i) != 0))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bits_are_named_from_bit_0() {
        let bits = inputs_of(0b101, &["a", "b", "c"]);
        let values: Vec<bool> = bits.iter().map(|b| b.value).collect();
        assert_eq!(values, [true, false, true]);
        assert_eq!(bits[2].name, "c");
        let o = output(
            "A1",
            true,
            OutputId {
                group: 1,
                bit: None,
            },
            true,
        );
        assert!(o.hazardous && o.output.is_some());
        assert_eq!(group("g", Some(5), bits).raw, Some(5));
    }
}
