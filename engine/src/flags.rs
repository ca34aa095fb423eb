//! What a unit is and what is on it, as bit sets: numbers an agent in any language can test
//! (the wire carries the bits, `UnitState.msg` names them), and names for text and JSON.

use serde::ser::{Serialize, SerializeSeq, Serializer};
use std::fmt;

/// A bit in a set that [`UnitFlags::from_bits`] or [`Buffs::from_bits`] does not know.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{set}: unknown bits {bits:#x}")]
pub struct UnknownBits {
    pub set: &'static str,
    pub bits: u32,
}

macro_rules! bit_set {
    ($(#[$doc:meta])* $name:ident { $($flag:ident = $bit:literal => $text:literal,)+ }) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Default, PartialEq, Eq, Hash)]
        pub struct $name(u32);

        impl $name {
            $(pub const $flag: $name = $name(1 << $bit);)+
            /// Every bit with its name, in bit order.
            pub const NAMES: &'static [($name, &'static str)] = &[$(($name::$flag, $text),)+];
            /// The constant names as `.msg` files spell them, with their values.
            pub const CONSTANTS: &'static [(&'static str, u32)] = &[$((stringify!($flag), 1 << $bit),)+];
            const KNOWN: u32 = 0 $(| (1 << $bit))+;

            pub const fn empty() -> Self {
                $name(0)
            }
            pub const fn bits(self) -> u32 {
                self.0
            }
            /// The set a wire value stands for; unknown bits are an error, not dropped.
            pub fn from_bits(bits: u32) -> Result<Self, UnknownBits> {
                if bits & !Self::KNOWN == 0 {
                    Ok($name(bits))
                } else {
                    Err(UnknownBits { set: stringify!($name), bits: bits & !Self::KNOWN })
                }
            }
            pub const fn contains(self, o: $name) -> bool {
                self.0 & o.0 == o.0
            }
            pub fn insert(&mut self, o: $name) {
                self.0 |= o.0;
            }
            pub const fn is_empty(self) -> bool {
                self.0 == 0
            }
            /// Names of the bits set, in bit order.
            pub fn names(self) -> impl Iterator<Item = &'static str> {
                Self::NAMES.iter().filter(move |(f, _)| self.contains(*f)).map(|(_, n)| *n)
            }
        }

        impl fmt::Debug for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.debug_set().entries(self.names()).finish()
            }
        }

        /// As a list of names, so JSON reads as before (`["flying", "light"]`).
        impl Serialize for $name {
            fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                let mut seq = s.serialize_seq(None)?;
                for n in self.names() {
                    seq.serialize_element(n)?;
                }
                seq.end()
            }
        }
    };
}

bit_set! {
    /// Properties of a unit's type and mode (attributes included).
    UnitFlags {
        FLYING = 0 => "flying",
        STRUCTURE = 1 => "structure",
        DETECTOR = 2 => "detector",
        HEALER = 3 => "healer",
        CLIFF_WALKER = 4 => "cliff_walker",
        SIEGED = 5 => "sieged",
        PHASING = 6 => "phasing",
        ASSAULT_MODE = 7 => "assault_mode",
        FIGHTER_MODE = 8 => "fighter_mode",
        IMMOBILE = 9 => "immobile",
        LIGHT = 10 => "light",
        ARMORED = 11 => "armored",
        BIOLOGICAL = 12 => "biological",
        MECHANICAL = 13 => "mechanical",
        PSIONIC = 14 => "psionic",
        MASSIVE = 15 => "massive",
    }
}

bit_set! {
    /// Buffs and states active on a unit now. `WINDING_UP`: an attack has started and its
    /// effect has not fired yet (the game shows the attack animation); an order that moves
    /// the unit now cancels the attack.
    Buffs {
        STIMMED = 0 => "stimmed",
        SLOWED = 1 => "slowed",
        AFTERBURNERS = 2 => "afterburners",
        GUARDIAN_SHIELD = 3 => "guardian_shield",
        GUARDIAN_SHIELDED = 4 => "guardian_shielded",
        BARRIER = 5 => "barrier",
        CLOAKED = 6 => "cloaked",
        LIFTED = 7 => "lifted",
        TRANSFUSING = 8 => "transfusing",
        MORPHING = 9 => "morphing",
        CHANNELLING = 10 => "channelling",
        DETECTED = 11 => "detected",
        WINDING_UP = 12 => "winding_up",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bits_names_and_unknown_bits() {
        let mut f = UnitFlags::FLYING;
        f.insert(UnitFlags::MASSIVE);
        assert_eq!(f.names().collect::<Vec<_>>(), ["flying", "massive"]);
        assert_eq!(UnitFlags::from_bits(f.bits()), Ok(f));
        assert_eq!(UnitFlags::from_bits(1 << 31), Err(UnknownBits { set: "UnitFlags", bits: 1 << 31 }));
        assert_eq!(serde_json::to_string(&f).ok().as_deref(), Some(r#"["flying","massive"]"#));
        assert!(Buffs::empty().is_empty() && Buffs::CONSTANTS.len() == Buffs::NAMES.len());
    }
}
