//! What a tile records about the render it is part of, so that `stitch` can refuse tiles of
//! different renders: a digest of everything that decides the pixels (scene files' contents,
//! resolved settings, frame, crate version) and the few settings most worth naming in a message.
//!
//! The digest is 64-bit FNV-1a, written here so that it is stable across Rust versions and
//! platforms (std's `DefaultHasher` promises neither). It is not a cryptographic hash: it guards
//! against mixing renders by mistake, not against forgery.

/// The PNG text-chunk keyword (and EXR header attribute name) that holds a [`RenderRecord`].
pub const RENDER_KEY: &str = "phongrt:render";

/// A 64-bit FNV-1a hasher over length-prefixed parts.
#[derive(Clone, Copy, Debug)]
pub struct Digest(u64);

impl Default for Digest {
    fn default() -> Self {
        Digest(0xcbf2_9ce4_8422_2325)
    }
}

impl Digest {
    /// Feed raw bytes.
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= x as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// Feed one labelled part; the label and the length keep parts from running into each other.
    pub fn part(&mut self, label: &str, data: &[u8]) {
        self.bytes(&(label.len() as u64).to_le_bytes());
        self.bytes(label.as_bytes());
        self.bytes(&(data.len() as u64).to_le_bytes());
        self.bytes(data);
    }

    /// The digest so far.
    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// A render's digest and its readable settings, as recorded in each tile.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RenderRecord {
    /// The digest of everything that decides the pixels.
    pub digest: u64,
    /// Readable settings (`seed`, `frame`, `spp`, `mode`, `scene`, `version`), in order.
    pub fields: Vec<(String, String)>,
}

impl RenderRecord {
    /// `"digest=HEX; key=value; ..."`; values are made printable ASCII without `;`.
    pub fn to_text(&self) -> String {
        let mut s = format!("digest={:016x}", self.digest);
        for (k, v) in &self.fields {
            let v: String = v
                .chars()
                .map(|c| if c.is_ascii_graphic() && c != ';' || c == ' ' { c } else { '?' })
                .collect();
            s.push_str(&format!("; {k}={v}"));
        }
        s
    }

    /// The inverse of [`RenderRecord::to_text`].
    pub fn from_text(s: &str) -> Option<RenderRecord> {
        let mut parts = s.split("; ");
        let digest = u64::from_str_radix(parts.next()?.strip_prefix("digest=")?, 16).ok()?;
        let fields = parts
            .map(|p| p.split_once('=').map(|(k, v)| (k.to_string(), v.to_string())))
            .collect::<Option<_>>()?;
        Some(RenderRecord { digest, fields })
    }

    /// The first readable setting both records have with different values: (key, self's, other's).
    pub fn first_difference<'a>(&'a self, other: &'a RenderRecord) -> Option<(&'a str, &'a str, &'a str)> {
        self.fields.iter().find_map(|(k, v)| {
            let (_, w) = other.fields.iter().find(|(k2, _)| k2 == k)?;
            (v != w).then_some((k.as_str(), v.as_str(), w.as_str()))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fnv1a_of_known_input_matches_the_reference_value() {
        // FNV-1a 64 of "a" is 0xaf63dc4c8601ec8c (the reference test vector).
        let mut d = Digest::default();
        d.bytes(b"a");
        assert_eq!(d.finish(), 0xaf63_dc4c_8601_ec8c);
    }

    #[test]
    fn record_text_round_trips_and_names_the_differing_setting() {
        let r = RenderRecord {
            digest: 0x0123_4567_89ab_cdef,
            fields: vec![("seed".into(), "6".into()), ("scene".into(), "duck bill.obj".into())],
        };
        let back = RenderRecord::from_text(&r.to_text()).unwrap();
        assert_eq!(back, r);
        let mut o = r.clone();
        o.fields[1].1 = "teapot.obj".into();
        assert_eq!(r.first_difference(&o), Some(("scene", "duck bill.obj", "teapot.obj")));
        assert_eq!(RenderRecord::from_text("seed=6"), None);
    }
}
