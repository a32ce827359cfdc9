//! Reading the OBJ: load options from the flags, the file's warnings printed, and --object's NAME=MODE.

use std::path::Path;

use anyhow::bail;

use crate::cli::LoadArgs;
use crate::progress::Stage;
use crate::Usage;
use phongrt::scene::{self, LoadOptions};
use phongrt_render::SurfaceMode;

/// Refuse a file that is plainly not an OBJ (by its extension) before reading it.
pub(crate) fn check_obj_path(path: &Path) -> anyhow::Result<()> {
    if let Some(ext) = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()) {
        if ext != "obj" {
            bail!("{}: not an OBJ file (.{ext}); phongrt reads Wavefront .obj meshes", path.display());
        }
    }
    Ok(())
}

pub(crate) fn load_options(args: &LoadArgs, crease_angle: f32) -> anyhow::Result<LoadOptions> {
    if !(0.0..=180.0).contains(&crease_angle) {
        usage!("--crease-angle {crease_angle} is not in [0, 180] degrees");
    }
    let small = args.small_face_crease_angle;
    if !(0.0..=180.0).contains(&small) {
        usage!("--small-face-crease-angle {small} is not in [0, 180] degrees");
    }
    let tol = args.normal_tolerance;
    if !(0.0..=0.1).contains(&tol) {
        usage!("--normal-tolerance {tol} is not in [0, 0.1] radians");
    }
    if args.bulge_limit.is_nan() || args.bulge_limit <= 0.0 {
        usage!("--bulge-limit {} is not a positive number (inf turns the rule off)", args.bulge_limit);
    }
    Ok(LoadOptions {
        crease_angle_deg: crease_angle,
        small_face_crease_angle_deg: small,
        normal_tolerance_rad: tol,
        drop_duplicate_faces: !args.keep_duplicate_faces,
        bulge_limit: args.bulge_limit,
        ..LoadOptions::default()
    })
}

/// Read the OBJ at `path`, with a spinner on a terminal when it takes beyond a second and
/// `show`, then print its warnings.
pub(crate) fn load(path: &Path, opts: &LoadOptions, show: bool) -> anyhow::Result<scene::Model> {
    check_obj_path(path)?;
    let name = path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into());
    let loading = Stage::start(format!("loading {name}"), show);
    let s = scene::load_obj(path, opts);
    drop(loading);
    let s = s?;
    for w in &s.warnings {
        eprintln!("phongrt: warning: {w}");
    }
    Ok(s)
}

/// `NAME=flat` or `NAME=phong[:ALPHA]`: the name, the mode and the alpha if given (see
/// [`SurfaceMode::over`] for one left out).
pub(crate) fn parse_object_override(s: &str) -> anyhow::Result<(String, SurfaceMode, Option<f32>)> {
    let Some((name, mode)) = s.rsplit_once('=') else {
        usage!("--object {s:?}: expected NAME=flat or NAME=phong[:ALPHA]");
    };
    let (mode_name, alpha) = match mode.split_once(':') {
        Some((m, a)) => (m, Some(a)),
        None => (mode, None),
    };
    // The names are --mode's (and the scene file's `mode`).
    let (mode, alpha) = match (SurfaceMode::from_name(mode_name).ok_or(()), alpha) {
        (Ok(m), None) => (m, None),
        (Ok(SurfaceMode::Phong), Some(a)) => {
            let Ok(alpha) = a.parse::<f32>() else {
                usage!("--object {s:?}: alpha {a:?} is not a number");
            };
            if !(0.0..=1.0).contains(&alpha) {
                usage!("--object {s:?}: alpha {alpha} is not in [0, 1]");
            }
            (SurfaceMode::Phong, Some(alpha))
        }
        _ => usage!("--object {s:?}: mode must be flat, phong or phong:ALPHA"),
    };
    Ok((name.to_string(), mode, alpha))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_object_override_without_alpha_gives_none_for_the_prior_alpha_to_stay() {
        let parse = |s: &str| parse_object_override(s).map_err(|e| e.to_string());
        assert_eq!(parse("head=phong"), Ok(("head".into(), SurfaceMode::Phong, None)));
        assert_eq!(parse("*=phong:0.5"), Ok(("*".into(), SurfaceMode::Phong, Some(0.5))));
        assert_eq!(parse("a=b=flat"), Ok(("a=b".into(), SurfaceMode::Flat, None)));
        assert!(parse("head=flat:0.5").unwrap_err().contains("mode must be flat, phong or phong:ALPHA"));
        assert!(parse("head=phong:2").unwrap_err().contains("not in [0, 1]"));
    }
}
