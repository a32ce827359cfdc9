//! Tiles (`render --tile` or `--crop` outputs) assembled into one image: every pixel covered
//! exactly once, all of one frame size, one kind and one render.

use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::image_out::{self, EncodeOptions, ImageError, ImageFormat, Tile, TilePixels};
use crate::render_record::{RenderRecord, RENDER_KEY};
use crate::{Image, Window};

/// Why tiles were not stitched.
#[derive(Debug, thiserror::Error)]
pub enum StitchError {
    /// The output, or the tiles, do not make one image: the message names the file and what is
    /// wrong (a mistake in what was asked for, not an unreadable file).
    #[error("stitch: {0}")]
    Refused(String),
    /// A tile could not be read, or the output encoded or written.
    #[error(transparent)]
    Image(#[from] ImageError),
}

/// Return early with [`StitchError::Refused`].
macro_rules! refuse {
    ($($t:tt)*) => { return Err(StitchError::Refused(format!($($t)*))) };
}

/// What was stitched.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stitched {
    /// The full frame's width.
    pub width: u32,
    /// The full frame's height.
    pub height: u32,
    /// The tiles it was made of.
    pub tiles: usize,
}

/// Assemble `tiles` (in any order) into `output` (.png or .exr), replaced only by a complete
/// file. Nothing is written unless every check passes.
pub fn stitch(output: &Path, tiles: &[PathBuf]) -> Result<Stitched, StitchError> {
    let format = check_output(output, tiles)?;
    if tiles.is_empty() {
        refuse!("no tiles given");
    }
    let mut read: Vec<(String, Tile)> = Vec::new();
    for p in tiles {
        read.push((p.display().to_string(), image_out::read_tile(p)?));
    }
    check_tiles(&read)?;
    let bytes = assemble(&read, format, output)?;
    image_out::write_atomically(output, &bytes)?;
    let w = &read[0].1.window;
    Ok(Stitched { width: w.full_width, height: w.full_height, tiles: read.len() })
}

/// The output's format, once it is known not to be one of the tiles and to be writable.
fn check_output(output: &Path, tiles: &[PathBuf]) -> Result<ImageFormat, StitchError> {
    let format = ImageFormat::from_path(output).map_err(|e| StitchError::Refused(e.to_string()))?;
    if let Some(input) = crate::temp_file::input_that_is(output, tiles) {
        refuse!(
            "the output {} is the input tile {} (the same file): writing it would destroy the tile",
            output.display(),
            input.display()
        );
    }
    image_out::check_writable(output)?;
    Ok(format)
}

/// A tile's kind: ("PNG", channels) or ("EXR", channels).
fn kind(t: &Tile) -> (&'static str, usize) {
    match t.pixels {
        TilePixels::Srgb8 { channels, .. } => ("PNG", channels),
        TilePixels::Linear { channels, .. } => ("EXR", channels),
    }
}

/// Refuse tiles of different frame sizes, kinds or renders, tiles that overlap, and tiles that
/// leave pixels uncovered.
fn check_tiles(tiles: &[(String, Tile)]) -> Result<(), StitchError> {
    let (first_name, first) = &tiles[0];
    let (fw, fh) = (first.window.full_width, first.window.full_height);
    for (name, t) in tiles {
        let w = &t.window;
        if (w.full_width, w.full_height) != (fw, fh) {
            refuse!(
                "{name}: tile {} is of a {}x{} frame, but {first_name} is of a {fw}x{fh} frame",
                w.to_text(),
                w.full_width,
                w.full_height
            );
        }
        if kind(t) != kind(first) {
            refuse!(
                "{name}: a {} tile with {} channels, but {first_name} is {} with {}",
                kind(t).0,
                kind(t).1,
                kind(first).0,
                kind(first).1
            );
        }
    }
    check_same_render(tiles)?;
    for (i, (a_name, a)) in tiles.iter().enumerate() {
        for (b_name, b) in &tiles[i + 1..] {
            if a.window.overlaps(&b.window) {
                refuse!("{b_name}: window {} overlaps {a_name}'s {}", b.window.to_text(), a.window.to_text());
            }
        }
    }
    let covered: u64 = tiles.iter().map(|(_, t)| t.window.width() as u64 * t.window.height() as u64).sum();
    if covered != fw as u64 * fh as u64 {
        refuse!(
            "the tiles cover {covered} of the {fw}x{fh} frame's {} pixels (missing tiles?)",
            fw as u64 * fh as u64
        );
    }
    Ok(())
}

/// Refuse tiles of different renders (their digests differ) and tiles that record none.
fn check_same_render(tiles: &[(String, Tile)]) -> Result<(), StitchError> {
    let mut records = Vec::new();
    for (name, t) in tiles {
        let Some(text) = &t.render else {
            refuse!(
                "{name}: records no render digest (a tile of an older phongrt, or not a tile); render it again"
            );
        };
        let Some(r) = RenderRecord::from_text(text) else {
            refuse!("{name}: malformed {RENDER_KEY} {text:?}");
        };
        records.push(r);
    }
    let (first_name, first) = (&tiles[0].0, &records[0]);
    for ((name, _), r) in tiles.iter().zip(&records).skip(1) {
        if r.digest == first.digest {
            continue;
        }
        match first.first_difference(r) {
            Some((key, a, b)) => {
                refuse!("{name} and {first_name} are tiles of different renders: {key} {b} in {name}, {a} in {first_name}")
            }
            None => refuse!(
                "{name} and {first_name} are tiles of different renders: their scene files or settings differ \
                 (digest {:016x} vs {:016x})",
                r.digest,
                first.digest
            ),
        }
    }
    Ok(())
}

/// The checked tiles' pixels in one frame, encoded as `format`.
fn assemble(tiles: &[(String, Tile)], format: ImageFormat, output: &Path) -> Result<Vec<u8>, StitchError> {
    let first = &tiles[0].1;
    let (fw, fh) = (first.window.full_width, first.window.full_height);
    let (is_png, channels) = (kind(first).0 == "PNG", kind(first).1);
    let n = fw as usize * fh as usize * channels;
    if is_png {
        let mut data = vec![0u8; n];
        for (_, t) in tiles {
            let TilePixels::Srgb8 { data: src, .. } = &t.pixels else { unreachable!("checked above") };
            blit_rows(&mut data, src, &t.window, fw, channels);
        }
        return match format {
            ImageFormat::Png => Ok(image_out::encode_png8(fw, fh, channels == 4, &data, None, None)?),
            ImageFormat::Exr => refuse!(
                "{}: PNG tiles are 8-bit sRGB; stitch them to .png (EXR output needs EXR tiles)",
                output.display()
            ),
        };
    }
    let mut data = vec![0f32; n];
    for (_, t) in tiles {
        let TilePixels::Linear { data: src, .. } = &t.pixels else { unreachable!("checked above") };
        blit_rows(&mut data, src, &t.window, fw, channels);
    }
    let mut img = Image::new(fw, fh);
    let mut alpha = Vec::new();
    for (i, px) in data.chunks_exact(channels).enumerate() {
        img.pixels[i] = Vec3::new(px[0], px[1], px[2]);
        if channels == 4 {
            alpha.push(px[3]);
        }
    }
    let opts = EncodeOptions { alpha: (channels == 4).then_some(&alpha[..]), ..Default::default() };
    Ok(image_out::encode(&img, format, &opts)?)
}

/// Copy a tile's rows into the full frame.
fn blit_rows<T: Copy>(dst: &mut [T], src: &[T], w: &Window, full_width: u32, channels: usize) {
    let row = w.width() as usize * channels;
    for (r, line) in src.chunks_exact(row).enumerate() {
        let at = ((w.y0 as usize + r) * full_width as usize + w.x0 as usize) * channels;
        dst[at..at + row].copy_from_slice(line);
    }
}
