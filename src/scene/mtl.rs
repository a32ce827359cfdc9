//! A Wavefront MTL parser of our own: the statements the renderer uses, as the spec writes them.
//!
//! Why not `tobj::load_mtl_buf`: it panics on the spec-valid one-value colour `Kd 0.8` (g and b
//! default to r), and one bad line drops the whole library without saying which. Here a colour
//! takes 1 or 3 numbers (or `xyz` and 1 or 3 numbers, read as RGB); `spectral` colours, unknown
//! statements and bad values are skipped, each counted in one warning naming a line.

use std::path::Path;

use glam::Vec3;

use super::{cut_token, Material};

/// What an MTL file defines; `diffuse_texture` is the name as written (resolved by the caller).
#[derive(Clone, Debug, Default)]
pub struct RawMaterial {
    /// The `newmtl` name.
    pub name: String,
    /// `Kd`, the diffuse colour.
    pub kd: Option<Vec3>,
    /// `Ks`, the specular colour.
    pub ks: Option<Vec3>,
    /// `Ke`, the emissive colour.
    pub ke: Option<Vec3>,
    /// `Ns`, the specular exponent.
    pub ns: Option<f32>,
    /// `Ni`, the index of refraction.
    pub ni: Option<f32>,
    /// `d`, the opacity; it wins over `Tr` when both are given.
    pub dissolve: Option<f32>,
    /// `Tr`, the transparency (`1 - d`).
    pub transparency: Option<f32>,
    /// `illum`, the illumination model number.
    pub illum: Option<u8>,
    /// The `map_Kd` file name (options dropped), as written.
    pub diffuse_texture: Option<String>,
}

impl RawMaterial {
    /// The renderer's material, with defaults where the file says nothing.
    pub fn to_material(&self, diffuse_texture: Option<std::path::PathBuf>) -> Material {
        let d = Material::default();
        let dissolve = self.dissolve.or(self.transparency.map(|t| 1.0 - t)).unwrap_or(1.0);
        Material {
            name: self.name.clone(),
            kd: self.kd.unwrap_or(d.kd),
            ks: self.ks.unwrap_or(d.ks),
            ke: self.ke.unwrap_or(d.ke),
            ns: self.ns.unwrap_or(d.ns),
            ni: self.ni.unwrap_or(d.ni),
            dissolve: dissolve.clamp(0.0, 1.0),
            illum: self.illum,
            diffuse_texture,
        }
    }
}

/// A parsed MTL file: its materials and, when lines were skipped, one warning saying how many
/// and naming the first.
#[derive(Clone, Debug, Default)]
pub struct RawMtl {
    /// The materials in file order (a repeated name appears twice; the first wins on lookup).
    pub materials: Vec<RawMaterial>,
    /// "FILE: skipped N unusable lines (first: line L: why)", when any line was skipped.
    pub warning: Option<String>,
}

/// Parse MTL text; `path` is for messages only. Never fails: bad lines are skipped and counted.
pub fn parse(text: &str, path: &Path) -> RawMtl {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut out = RawMtl::default();
    let mut cur: Option<RawMaterial> = None;
    let (mut skipped, mut first_bad): (usize, Option<String>) = (0, None);
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut words = line.split_whitespace();
        let Some(kw) = words.next() else { continue };
        let args: Vec<&str> = words.collect();
        let rest = line[kw.len()..].trim();
        let r = statement(kw, &args, rest, &mut cur, &mut out.materials);
        if let Err(why) = r {
            skipped += 1;
            if first_bad.is_none() {
                first_bad = Some(format!("line {}: {why}", i + 1));
            }
        }
    }
    out.materials.extend(cur);
    if let Some(first) = first_bad {
        out.warning = Some(format!("{}: skipped {skipped} unusable lines (first: {first})", path.display()));
    }
    out
}

/// Apply one statement to the material being defined.
fn statement(
    kw: &str,
    args: &[&str],
    rest: &str,
    cur: &mut Option<RawMaterial>,
    done: &mut Vec<RawMaterial>,
) -> Result<(), String> {
    if kw == "newmtl" {
        if rest.is_empty() {
            return Err("`newmtl` without a name".into());
        }
        done.extend(cur.take());
        *cur = Some(RawMaterial { name: rest.to_string(), ..Default::default() });
        return Ok(());
    }
    // Statements we do not use are fine anywhere; the rest need a `newmtl` first.
    let used = ["Kd", "Ks", "Ke", "Ns", "Ni", "d", "Tr", "illum", "map_Kd"];
    if !used.contains(&kw) {
        return Ok(());
    }
    let Some(m) = cur.as_mut() else {
        return Err(format!("`{}` before any `newmtl`", cut_token(kw)));
    };
    match kw {
        "Kd" => m.kd = Some(colour(kw, args)?),
        "Ks" => m.ks = Some(colour(kw, args)?),
        "Ke" => m.ke = Some(colour(kw, args)?),
        "Ns" => m.ns = Some(scalar(kw, args)?),
        "Ni" => m.ni = Some(scalar(kw, args)?),
        "d" => {
            // `d -halo 0.5`: the halo form, read as plain dissolve.
            let a = if args.first() == Some(&"-halo") { &args[1..] } else { args };
            m.dissolve = Some(scalar(kw, a)?);
        }
        "Tr" => m.transparency = Some(scalar(kw, args)?),
        "illum" => {
            let a = args.first().ok_or("`illum` needs a number")?;
            m.illum = Some(a.parse().map_err(|_| format!("`illum`: {} is not in 0..=255", cut_token(a)))?);
        }
        "map_Kd" => m.diffuse_texture = Some(texture_file(args)?),
        _ => {}
    }
    Ok(())
}

fn number(kw: &str, a: &str) -> Result<f32, String> {
    let x: f32 = a.parse().map_err(|_| format!("`{kw}`: {} is not a number", cut_token(a)))?;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(format!("`{kw}`: {} is not a finite number", cut_token(a)))
    }
}

fn scalar(kw: &str, args: &[&str]) -> Result<f32, String> {
    number(kw, args.first().ok_or_else(|| format!("`{kw}` needs a number"))?)
}

/// `r [g b]` (g and b default to r), or `xyz x [y z]` read as RGB; `spectral` is refused.
fn colour(kw: &str, args: &[&str]) -> Result<Vec3, String> {
    let args = match args.first() {
        Some(&"spectral") => return Err(format!("`{kw} spectral` colours are not supported")),
        Some(&"xyz") => &args[1..],
        _ => args,
    };
    let v: Vec<f32> = args.iter().map(|a| number(kw, a)).collect::<Result<_, _>>()?;
    match v[..] {
        [r] => Ok(Vec3::splat(r)),
        [r, g, b] => Ok(Vec3::new(r, g, b)),
        _ => Err(format!("`{kw}` needs 1 or 3 numbers, found {}", v.len())),
    }
}

/// The file name of `map_Kd [options] file`: options take the number of values the spec gives.
fn texture_file(args: &[&str]) -> Result<String, String> {
    let mut i = 0;
    while i < args.len() {
        let n = match args[i] {
            "-blendu" | "-blendv" | "-cc" | "-clamp" | "-imfchan" | "-bm" | "-boost" | "-texres" => 1,
            "-mm" => 2,
            "-o" | "-s" | "-t" => {
                // 1 to 3 numbers.
                let k = args[i + 1..].iter().take(3).take_while(|a| a.parse::<f32>().is_ok()).count();
                k.max(1)
            }
            _ => break,
        };
        i += 1 + n;
    }
    let name = args.get(i..).map(|a| a.join(" ")).unwrap_or_default();
    if name.is_empty() {
        Err("`map_Kd` without a file name".into())
    } else {
        Ok(name)
    }
}
