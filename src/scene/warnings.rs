//! Repeated warnings folded into one line: 10,000 missing textures make one warning with the
//! first instance and a count, not 10,000 lines.

use std::collections::HashSet;

/// Warnings collected by kind, in order of first appearance; a message seen before is dropped.
#[derive(Debug, Default)]
pub struct FoldedWarnings {
    /// Per kind: the first message and how many distinct messages of that kind came.
    kinds: Vec<(&'static str, String, usize)>,
    seen: HashSet<String>,
}

impl FoldedWarnings {
    /// Record `message` as one of `kind` (a short name such as "missing texture").
    pub fn push(&mut self, kind: &'static str, message: String) {
        if !self.seen.insert(message.clone()) {
            return;
        }
        match self.kinds.iter_mut().find(|(k, _, _)| *k == kind) {
            Some((_, _, n)) => *n += 1,
            None => self.kinds.push((kind, message, 1)),
        }
    }

    /// One line per kind: its first message, and when there were more, how many in all.
    pub fn into_lines(self) -> impl Iterator<Item = String> {
        self.kinds.into_iter().map(|(kind, first, n)| match n {
            1 => first,
            n => format!("{first} (and {} more: {n} warnings of this kind, {kind})", n - 1),
        })
    }
}
