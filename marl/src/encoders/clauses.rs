//! The vision-text description cut into the pieces that repeat, each assigned to a slot.
//!
//! A whole description changes at every step (game time, positions, health), so embedding
//! it whole never hits a cache; its clauses (`HP 37/45`, `at grid (3, 4)`, `attacking enemy
//! Marine_2 (tag 5)`) come back step after step and episode after episode. This module
//! parses the engine's [`describe`](avacraft_engine::describe) text (it is not changed for
//! the MARL path: the VLM agents read it) into clauses and says which slot of the text
//! features each clause feeds:
//! - slot 0, the header: every line that is not an item (scenario and game time, objective,
//!   grid, the own and enemy counts), cut into sentences;
//! - one slot per own agent, in agent order, found by the unit line's tag;
//! - one slot per enemy of the scenario's roster, in tag order (SMAC's enemy order);
//! - a last slot for the rest: area effects, and units outside the rosters (spawned ones).
//!
//! A unit line `- NAME (tag T, KIND): A, B, ...; status: S; abilities: X, Y [FLAGS].` gives the
//! clauses `NAME (tag T, KIND)`, `A`, `B`, ..., `status: S`, `abilities: X`,
//! `abilities: Y`, `[FLAGS]`; a piece that starts with `(` stays with the one before it
//! (`attack-moving to (12, 18)` then `engaging ...`; an effect's centre with its grid cell).
//!
//! What the MARL text changes, beyond the cutting: in item lines, every `(x, y)` pair of
//! decimal numbers (move and attack-move targets, area-effect centres) is rounded to whole
//! map units, because those coordinates almost never repeat; and each ability is its own
//! clause with the list's `abilities: ` in front. Nothing is dropped, and nothing is cut at
//! a token limit any more (the whole 3m_vlm text ran past MiniLM's 256 tokens once enemies were
//! in sight).

use avacraft_engine::{Env, Team, UnitId};
use std::borrow::Cow;
use std::fmt::Write;
use std::ops::Range;

/// Which slot each unit line feeds: agents by their tag in agent order, enemies by tag.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SlotLayout {
    own: Vec<u32>,
    enemies: Vec<u32>,
}

/// The header's slot.
pub const HEADER: usize = 0;

/// Slots for `n_agents` agents and `n_enemies` enemies: header, agents, enemies, the rest.
pub fn slot_count(n_agents: usize, n_enemies: usize) -> usize {
    n_agents + n_enemies + 2
}

impl SlotLayout {
    /// `own`: the agents' unit tags in agent order; `enemies`: the enemy roster's tags (any
    /// order: slots follow ascending tags).
    pub fn new(own: Vec<u32>, mut enemies: Vec<u32>) -> SlotLayout {
        enemies.sort_unstable();
        SlotLayout { own, enemies }
    }

    /// `team`'s layout in `env`: its agents, and the other team's units in the scenario
    /// (tags are scenario indices plus one, so they are the same in every episode).
    pub fn of(env: &Env, team: Team) -> SlotLayout {
        let own = env.agents(team).iter().map(|id| id.tag()).collect();
        let enemies = env.scenario().team_units(team.other()).map(|(i, _)| UnitId::new(i as u16).tag()).collect();
        SlotLayout::new(own, enemies)
    }

    pub fn slots(&self) -> usize {
        slot_count(self.own.len(), self.enemies.len())
    }
    /// The slot of everything without a place of its own.
    pub fn extra(&self) -> usize {
        self.slots() - 1
    }
    fn own_slot(&self, tag: u32) -> usize {
        self.own.iter().position(|&t| t == tag).map_or(self.extra(), |i| 1 + i)
    }
    fn enemy_slot(&self, tag: u32) -> usize {
        self.enemies.binary_search(&tag).map_or(self.extra(), |i| 1 + self.own.len() + i)
    }
}

/// One clause of a description and the slot it feeds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Clause<'a> {
    pub slot: usize,
    pub text: Cow<'a, str>,
}

/// A piece of a line: a byte range of it, and text put in front when it is embedded.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Piece {
    pub range: Range<usize>,
    pub prefix: &'static str,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Section {
    Header,
    Own,
    Enemy,
    Effects,
    Other,
}

/// The clauses of `text` (a [`describe`](avacraft_engine::describe) output) in text order.
pub fn clauses<'a>(text: &'a str, layout: &SlotLayout) -> Vec<Clause<'a>> {
    let mut out = Vec::new();
    let mut section = Section::Header;
    for line in text.lines().filter(|l| !l.trim().is_empty()) {
        if line.starts_with("- ") {
            let (tag, pieces) = item_pieces(line);
            let slot = match (section, tag) {
                (Section::Own, Some(t)) => layout.own_slot(t),
                (Section::Enemy, Some(t)) => layout.enemy_slot(t),
                _ => layout.extra(),
            };
            for p in pieces {
                let body = round_points(&line[p.range]);
                let text = if p.prefix.is_empty() { body } else { Cow::Owned(format!("{}{body}", p.prefix)) };
                out.push(Clause { slot, text });
            }
        } else {
            section = if line.starts_with("Your units") {
                Section::Own
            } else if line.starts_with("Enemy units") || line.starts_with("No enemy units") {
                Section::Enemy
            } else if line.starts_with("Area effects") {
                Section::Effects
            } else if section == Section::Header {
                Section::Header
            } else {
                Section::Other
            };
            let slot = if section == Section::Effects { layout.extra() } else { HEADER };
            out.extend(sentences(line).into_iter().map(|r| Clause { slot, text: Cow::Borrowed(&line[r]) }));
        }
    }
    out
}

/// Byte ranges of a header line's sentences (each with its full stop).
pub fn sentences(line: &str) -> Vec<Range<usize>> {
    let mut out = split_top(line, 0..line.len(), ". ");
    let last = out.len().saturating_sub(1);
    for r in &mut out[..last] {
        r.end += 1;
    }
    out
}

/// The tag (when it names one) and the pieces of an item line (`- ...`).
pub fn item_pieces(line: &str) -> (Option<u32>, Vec<Piece>) {
    let plain = |range: Range<usize>| Piece { range, prefix: "" };
    let mut body = 2.min(line.len())..line.len();
    if line[body.clone()].ends_with('.') {
        body.end -= 1;
    }
    // Trailing flags: ` [flying, detector]`.
    let mut flags = None;
    if line[body.clone()].ends_with(']')
        && let Some(open) = line[body.clone()].rfind(" [")
    {
        let open = body.start + open;
        flags = Some(open + 1..body.end);
        body.end = open;
    }
    let mut tag = None;
    let mut pieces = Vec::new();
    for (k, part) in split_top(line, body, "; ").into_iter().enumerate() {
        let text = &line[part.clone()];
        if k == 0 {
            let list = match find_top(text, ": ") {
                Some(colon) => {
                    let id = part.start..part.start + colon;
                    tag = parse_tag(&line[id.clone()]);
                    pieces.push(plain(id));
                    part.start + colon + 2..part.end
                }
                None => part,
            };
            pieces.extend(merge_points(line, split_top(line, list, ", ")).into_iter().map(plain));
        } else if let Some(items) = text.strip_prefix("abilities: ") {
            let items = part.end - items.len()..part.end;
            pieces.extend(merge_points(line, split_top(line, items, ", ")).into_iter().map(|range| Piece { range, prefix: "abilities: " }));
        } else {
            pieces.push(plain(part));
        }
    }
    pieces.extend(flags.map(plain));
    pieces.retain(|p| !p.range.is_empty());
    (tag, pieces)
}

/// `T` of `NAME (tag T, KIND)`.
fn parse_tag(id: &str) -> Option<u32> {
    let rest = &id[id.find("(tag ")? + 5..];
    let end = rest.find(|c: char| !c.is_ascii_digit()).unwrap_or(rest.len());
    rest[..end].parse().ok()
}

/// Ranges of `s[range]` between occurrences of `sep` outside parentheses and brackets.
fn split_top(s: &str, range: Range<usize>, sep: &str) -> Vec<Range<usize>> {
    let mut out = Vec::new();
    let (mut depth, mut start) = (0i32, range.start);
    let bytes = s.as_bytes();
    let mut i = range.start;
    while i < range.end {
        match bytes[i] {
            b'(' | b'[' => depth += 1,
            b')' | b']' => depth -= 1,
            _ => {}
        }
        if depth == 0 && i + sep.len() <= range.end && s[i..].starts_with(sep) {
            out.push(start..i);
            i += sep.len();
            start = i;
            continue;
        }
        i += 1;
    }
    out.push(start..range.end);
    out
}

/// Where `sep` first occurs in `s` outside parentheses and brackets.
fn find_top(s: &str, sep: &str) -> Option<usize> {
    let first = split_top(s, 0..s.len(), sep).into_iter().next()?;
    (first.end < s.len()).then_some(first.end)
}

/// Joins each range that starts with `(` to the one before it (a point with its place).
fn merge_points(s: &str, ranges: Vec<Range<usize>>) -> Vec<Range<usize>> {
    let mut out: Vec<Range<usize>> = Vec::with_capacity(ranges.len());
    for r in ranges {
        match out.last_mut() {
            Some(prev) if s[r.clone()].starts_with('(') => prev.end = r.end,
            _ => out.push(r),
        }
    }
    out
}

/// `s` with every `(x, y)` pair of decimal numbers rounded to whole numbers (half away from
/// zero); borrowed when there is none.
pub fn round_points(s: &str) -> Cow<'_, str> {
    if !s.contains('.') {
        return Cow::Borrowed(s);
    }
    let mut out = String::new();
    let (mut copied, mut from) = (0, 0);
    while let Some(off) = s[from..].find('(') {
        let open = from + off;
        from = open + 1;
        let Some(len) = s[open + 1..].find(')') else { break };
        let inner = &s[open + 1..open + 1 + len];
        let Some((x, y)) = inner.split_once(", ") else { continue };
        let (Some(x), Some(y)) = (decimal(x), decimal(y)) else { continue };
        out.push_str(&s[copied..open]);
        let _ = write!(out, "({}, {})", whole(x), whole(y));
        copied = open + len + 2;
        from = copied;
    }
    if copied == 0 {
        return Cow::Borrowed(s);
    }
    out.push_str(&s[copied..]);
    Cow::Owned(out)
}

/// A number written with a decimal point (`12.3`, `-0.5`).
fn decimal(t: &str) -> Option<f64> {
    let digits = t.strip_prefix('-').unwrap_or(t);
    let (a, b) = digits.split_once('.')?;
    let ok = |p: &str| !p.is_empty() && p.bytes().all(|c| c.is_ascii_digit());
    (ok(a) && ok(b)).then(|| t.parse().ok()).flatten()
}

fn whole(x: f64) -> i64 {
    // `as` saturates; -0.4 rounds to 0, printed without a sign.
    x.round() as i64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_round_to_whole_units_and_other_numbers_stay() {
        assert_eq!(round_points("moving to (12.3, 17.5)"), "moving to (12, 18)");
        assert_eq!(round_points("attack-moving to (0.4, 31.6)"), "attack-moving to (0, 32)");
        assert_eq!(round_points("at grid (3, 4)"), "at grid (3, 4)");
        assert!(matches!(round_points("weapon ready in 0.4 s"), Cow::Borrowed(_)));
        assert_eq!(round_points("own psi storm at grid (3, 4), (12.3, 17.8)"), "own psi storm at grid (3, 4), (12, 18)");
        assert_eq!(round_points("(1.5, x) (2.5, 3.5)"), "(1.5, x) (3, 4)");
    }

    #[test]
    fn a_unit_line_cuts_into_its_clauses() {
        let line = "- Marine_1 (tag 3, Siege Tank (sieged)): HP 40/45, weapon ready in 0.4 s, at grid (3, 4), \
                    attack-moving to (12.3, 17.8), engaging enemy Zealot_2 (tag 7); status: stimmed, slowed; \
                    abilities: stim ready, blink in 2.0 s, feedback unavailable (not enough energy) [flying, detector].";
        let (tag, pieces) = item_pieces(line);
        assert_eq!(tag, Some(3));
        let text: Vec<String> = pieces.iter().map(|p| format!("{}{}", p.prefix, &line[p.range.clone()])).collect();
        assert_eq!(
            text,
            [
                "Marine_1 (tag 3, Siege Tank (sieged))",
                "HP 40/45",
                "weapon ready in 0.4 s",
                "at grid (3, 4)",
                "attack-moving to (12.3, 17.8)",
                "engaging enemy Zealot_2 (tag 7)",
                "status: stimmed, slowed",
                "abilities: stim ready",
                "abilities: blink in 2.0 s",
                "abilities: feedback unavailable (not enough energy)",
                "[flying, detector]",
            ]
        );
    }

    #[test]
    fn header_lines_cut_into_sentences() {
        let line = "Scenario 3m_vlm (pve), you are player 1. Game time 1.5 s of 120 s (loop 32 of 2688).";
        let s: Vec<&str> = sentences(line).into_iter().map(|r| &line[r]).collect();
        assert_eq!(s, ["Scenario 3m_vlm (pve), you are player 1.", "Game time 1.5 s of 120 s (loop 32 of 2688)."]);
    }
}
