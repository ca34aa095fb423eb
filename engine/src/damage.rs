//! StarCraft II's damage model: bonus by attribute, shields first, hull armour per hit,
//! at least half a point per hit on an unshielded hull.

use crate::units::{Attrs, Weapon};

/// Damage of one hit of `w` against a target with `attrs`, before shields and armour.
pub fn hit_damage(w: &Weapon, attrs: Attrs) -> f32 {
    w.damage + w.bonus.iter().filter(|(a, _)| attrs.has(*a)).map(|(_, d)| d).sum::<f32>()
}

/// What one application of damage did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Dealt {
    pub shield: f32,
    pub hp: f32,
    /// Taken by a Barrier.
    pub absorbed: f32,
}

impl Dealt {
    pub fn total(&self) -> f32 {
        self.shield + self.hp
    }
}

/// Applies `hits` hits of `per_hit` (already scaled by any splash fraction) to a target's
/// shield and HP. Shields absorb first (shield armour 0); what passes them loses the hull
/// armour; a hit entirely on the hull deals at least 0.5.
pub fn apply_hits(per_hit: f32, hits: u8, armor: f32, shield: &mut f32, hp: &mut f32) -> Dealt {
    apply_hits_absorbed(per_hit, hits, armor, None, shield, hp)
}

/// [`apply_hits`] with an absorbing layer in front of the shields (Immortal Barrier):
/// whatever it absorbs never reaches shields or hull.
pub fn apply_hits_absorbed(per_hit: f32, hits: u8, armor: f32, mut barrier: Option<&mut f32>, shield: &mut f32, hp: &mut f32) -> Dealt {
    let mut out = Dealt::default();
    for _ in 0..hits {
        if *hp <= 0.0 {
            break;
        }
        let mut dmg = per_hit;
        if let Some(b) = barrier.as_deref_mut()
            && *b > 0.0
        {
            let absorbed = b.min(dmg);
            *b -= absorbed;
            out.absorbed += absorbed;
            dmg -= absorbed;
            if dmg <= 0.0 {
                continue;
            }
        }
        if *shield > 0.0 {
            let absorbed = shield.min(dmg);
            *shield -= absorbed;
            out.shield += absorbed;
            dmg -= absorbed;
            if dmg <= 0.0 {
                continue;
            }
            dmg = (dmg - armor).max(0.0);
        } else {
            dmg = (dmg - armor).max(0.5);
        }
        let taken = dmg.min(*hp);
        *hp -= dmg;
        out.hp += taken;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::units::UnitKind;

    #[test]
    fn marine_on_zealot_shields_then_hull() {
        let w = &UnitKind::Marine.spec_in(crate::units::DataSet::Legacy).weapons[0];
        let (mut sh, mut hp) = (50.0, 100.0);
        let d = apply_hits(hit_damage(w, UnitKind::Zealot.spec_in(crate::units::DataSet::Legacy).attrs), 1, 1.0, &mut sh, &mut hp);
        assert_eq!((d.shield, d.hp, sh, hp), (6.0, 0.0, 44.0, 100.0));
        let (mut sh, mut hp) = (0.0, 100.0);
        let d = apply_hits(6.0, 1, 1.0, &mut sh, &mut hp);
        assert_eq!((d.hp, hp), (5.0, 95.0));
    }

    #[test]
    fn spillover_loses_armour_and_minimum_is_half() {
        let (mut sh, mut hp) = (2.0, 100.0);
        apply_hits(6.0, 1, 1.0, &mut sh, &mut hp);
        assert_eq!((sh, hp), (0.0, 97.0));
        let (mut sh, mut hp) = (0.0, 500.0);
        apply_hits(1.0, 2, 2.0, &mut sh, &mut hp);
        assert_eq!(hp, 499.0);
    }

    #[test]
    fn bonus_damage_by_attribute() {
        let w = &UnitKind::Marauder.spec_in(crate::units::DataSet::Legacy).weapons[0];
        assert_eq!(hit_damage(w, UnitKind::Stalker.spec_in(crate::units::DataSet::Legacy).attrs), 20.0);
        assert_eq!(hit_damage(w, UnitKind::Zealot.spec_in(crate::units::DataSet::Legacy).attrs), 10.0);
        let bane = &UnitKind::Baneling.spec_in(crate::units::DataSet::Legacy).weapons[0];
        assert_eq!(hit_damage(bane, UnitKind::Marine.spec_in(crate::units::DataSet::Legacy).attrs), 35.0);
        assert_eq!(hit_damage(bane, UnitKind::PhotonCannon.spec_in(crate::units::DataSet::Legacy).attrs), 96.0);
    }
}
