//! Building the groups of an `IoSnapshot`: named bits read from the
//! controller, and outputs the operator may switch (with their `OutputId`).

use crate::device::api::{IoBit, IoGroup, OutputId};
use crate::wiring::BitWiring;

/// A bit read from the controller that is no wire (a status flag).
pub fn input(name: impl Into<String>, value: bool) -> IoBit {
    IoBit {
        name: name.into(),
        value,
        output: None,
        hazardous: false,
        wiring: None,
    }
}

/// An input as the profile has it wired, under the profile's name.
pub fn wired_input(wiring: &BitWiring, value: bool) -> IoBit {
    IoBit {
        name: wiring.name.clone(),
        value,
        output: None,
        hazardous: false,
        wiring: Some(wiring.clone()),
    }
}

/// A switchable output.
pub fn output(name: impl Into<String>, value: bool, id: OutputId, hazardous: bool) -> IoBit {
    IoBit {
        name: name.into(),
        value,
        output: Some(id),
        hazardous,
        wiring: None,
    }
}

/// A switchable output as the profile has it wired, under its name.
/// The profile's `hazardous` overrides the manual's.
pub fn wired_output(wiring: &BitWiring, value: bool, id: OutputId, hazardous: bool) -> IoBit {
    IoBit {
        wiring: Some(wiring.clone()),
        ..output(
            wiring.name.clone(),
            value,
            id,
            wiring.hazardous.unwrap_or(hazardous),
        )
    }
}

/// An input under the profile's name where the wiring knows `address`,
/// else under `fallback`.
pub fn input_at(
    wiring: &crate::wiring::Wiring,
    address: &str,
    fallback: &str,
    value: bool,
) -> IoBit {
    wiring
        .bit(address)
        .map_or_else(|| input(fallback, value), |w| wired_input(w, value))
}

/// An output under the profile's name where the wiring knows `address`.
pub fn output_at(
    wiring: &crate::wiring::Wiring,
    address: &str,
    fallback: &str,
    value: bool,
    id: OutputId,
    hazardous: bool,
) -> IoBit {
    wiring.bit(address).map_or_else(
        || output(fallback, value, id, hazardous),
        |w| wired_output(w, value, id, hazardous),
    )
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
