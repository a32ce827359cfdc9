//! Tiles (`render --tile` or `--crop` outputs) assembled into one image: every pixel covered
//! exactly once, all of one frame size, one kind and one render.

use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::image_out::{self, EncodeOptions, ImageError, ImageFormat, Tile, TileHeader, TilePixels};
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
/// file. Nothing is written unless every check passes, and the checks (of the headers) come
/// before any pixel is read: a tile claiming a huge size costs nothing. PNG tiles are streamed
/// row by row into the output (memory: a few rows, whatever the frame's size); EXR tiles and
/// their frame are held whole, so an EXR stitch that needs more than the memory budget
/// ([`memory_budget`]) is refused.
pub fn stitch(output: &Path, tiles: &[PathBuf]) -> Result<Stitched, StitchError> {
    let format = check_output(output, tiles)?;
    if tiles.is_empty() {
        refuse!("no tiles given");
    }
    let mut headers: Vec<(String, TileHeader)> = Vec::new();
    for p in tiles {
        headers.push((p.display().to_string(), image_out::read_tile_header(p)?));
    }
    check_tiles(&headers)?;
    let first = &headers[0].1;
    let (fw, fh) = (first.window.full_width, first.window.full_height);
    check_memory(&headers, memory_budget())?;
    match (first.format, format) {
        (ImageFormat::Png, ImageFormat::Png) => stream_png(output, tiles, &headers)?,
        (ImageFormat::Png, ImageFormat::Exr) => refuse!(
            "{}: PNG tiles are 8-bit sRGB; stitch them to .png (EXR output needs EXR tiles)",
            output.display()
        ),
        (ImageFormat::Exr, _) => {
            let mut read: Vec<(String, Tile)> = Vec::new();
            for (p, (name, h)) in tiles.iter().zip(&headers) {
                let t = image_out::read_tile(p)?;
                if (t.window, &t.render) != (h.window, &h.render) {
                    refuse!("{name}: changed while being stitched");
                }
                read.push((name.clone(), t));
            }
            let bytes = assemble_linear(&read, format)?;
            image_out::write_atomically(output, &bytes)?;
        }
    }
    Ok(Stitched { width: fw, height: fh, tiles: headers.len() })
}

/// The memory this machine lets a render or a stitch use: `PHONGRT_MAX_MEMORY` (bytes) if set, else
/// `MemAvailable` from /proc/meminfo; `None` when neither says.
pub fn memory_budget() -> Option<u64> {
    if let Some(v) = std::env::var_os("PHONGRT_MAX_MEMORY") {
        return v.to_str().and_then(|s| s.trim().parse().ok());
    }
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Bytes a stitch of these (checked) tiles needs, estimated from their headers.
/// - PNG, streamed: the output row and, per tile, its decoder (two rows, the inflate window and
///   the read buffer) and the encoder's deflate state.
/// - EXR, held whole: per frame pixel, each tile's decoded RGBA floats (16 bytes) and their copy
///   (12 or 16), the frame's samples (12 or 16), its image and alpha (16) and the encoded file
///   (up to 16): 72 bytes with alpha, as measured by the issue (53) rounded up.
pub fn stitch_memory(headers: &[(String, TileHeader)]) -> u64 {
    let first = &headers[0].1;
    let (fw, fh, ch) =
        (first.window.full_width as u64, first.window.full_height as u64, first.channels as u64);
    match first.format {
        ImageFormat::Png => {
            let per_tile: u64 =
                headers.iter().map(|(_, h)| 2 * h.window.width() as u64 * ch + (96 << 10)).sum();
            fw * ch * 2 + per_tile + (1 << 20)
        }
        ImageFormat::Exr => fw * fh * 72,
    }
}

/// Refuse a stitch that needs more than `budget` bytes.
fn check_memory(headers: &[(String, TileHeader)], budget: Option<u64>) -> Result<(), StitchError> {
    let need = stitch_memory(headers);
    let Some(budget) = budget.filter(|&b| need > b) else {
        return Ok(());
    };
    let w = &headers[0].1.window;
    let gb = |b: u64| format!("{:.2} GB", b as f64 / 1e9);
    let how = match headers[0].1.format {
        ImageFormat::Exr => "EXR tiles and their frame are held whole; PNG tiles are streamed row by row",
        ImageFormat::Png => "PNG tiles are streamed row by row",
    };
    refuse!(
        "the {}x{} frame needs about {} in memory, more than the {} allowed (PHONGRT_MAX_MEMORY, or \
         MemAvailable); {how}",
        w.full_width,
        w.full_height,
        gb(need),
        gb(budget)
    )
}

/// Stream PNG tiles into `output` one frame row at a time: each row is put together from the
/// tiles that cross it (opened at their first row, dropped after their last), then encoded.
fn stream_png(output: &Path, tiles: &[PathBuf], headers: &[(String, TileHeader)]) -> Result<(), ImageError> {
    use std::io::Write;
    let first = &headers[0].1;
    let (fw, fh, ch) = (first.window.full_width, first.window.full_height, first.channels);
    let out_error = |source| ImageError::Write { path: output.to_path_buf(), source };
    let target = std::fs::canonicalize(output).unwrap_or_else(|_| output.to_path_buf());
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let mut tmp = crate::temp_file::TempFile::create(&dir, &name).map_err(out_error)?;
    {
        let mut sink = std::io::BufWriter::new(tmp.file());
        let mut writer = image_out::png_writer(&mut sink, fw, fh, ch == 4, None, None)?;
        let mut stream = writer.stream_writer().map_err(ImageError::EncodePng)?;
        // Compute each row: the tiles in order of their first row, those open that cross it.
        let mut order: Vec<usize> = (0..headers.len()).collect();
        order.sort_by_key(|&i| (headers[i].1.window.y0, headers[i].1.window.x0));
        let mut next = order.iter().peekable();
        let mut open: Vec<(usize, image_out::PngReader)> = Vec::new();
        let mut row = vec![0u8; fw as usize * ch];
        for y in 0..fh {
            while let Some(&&i) = next.peek().filter(|&&&i| headers[i].1.window.y0 == y) {
                let (header, reader) = image_out::open_png_tile(&tiles[i])?;
                if header != headers[i].1 {
                    return Err(ImageError::Changed { path: tiles[i].clone() });
                }
                open.push((i, reader));
                next.next();
            }
            for (i, reader) in &mut open {
                let w = &headers[*i].1.window;
                let decode_error = |source| ImageError::DecodePng { path: tiles[*i].clone(), source };
                let src = reader.next_row().map_err(decode_error)?;
                let src = src.ok_or_else(|| decode_error(png::DecodingError::IoError(truncated())))?;
                let at = w.x0 as usize * ch;
                row[at..at + src.data().len()].copy_from_slice(src.data());
            }
            open.retain(|(i, _)| headers[*i].1.window.y1 > y + 1);
            stream.write_all(&row).map_err(out_error)?;
        }
        stream.finish().map_err(ImageError::EncodePng)?;
        writer.finish().map_err(ImageError::EncodePng)?;
        sink.flush().map_err(out_error)?;
    }
    tmp.file().sync_all().map_err(out_error)?;
    tmp.persist(&target).map_err(out_error)
}

/// A tile's image data ended before its last row.
fn truncated() -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::UnexpectedEof, "image data ends before the last row")
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
fn kind(t: &TileHeader) -> (&'static str, usize) {
    match t.format {
        ImageFormat::Png => ("PNG", t.channels),
        ImageFormat::Exr => ("EXR", t.channels),
    }
}

/// Refuse tiles of different frame sizes, kinds or renders, tiles that overlap, and tiles that
/// leave pixels uncovered.
fn check_tiles(tiles: &[(String, TileHeader)]) -> Result<(), StitchError> {
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
fn check_same_render(tiles: &[(String, TileHeader)]) -> Result<(), StitchError> {
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

/// The checked EXR tiles' pixels in one frame, encoded as `format`.
fn assemble_linear(tiles: &[(String, Tile)], format: ImageFormat) -> Result<Vec<u8>, StitchError> {
    let first = &tiles[0].1;
    let (fw, fh) = (first.window.full_width, first.window.full_height);
    let TilePixels::Linear { channels, .. } = first.pixels else { unreachable!("EXR tiles, checked above") };
    let mut data = vec![0f32; fw as usize * fh as usize * channels];
    for (name, t) in tiles {
        let TilePixels::Linear { data: src, .. } = &t.pixels else {
            refuse!("{name}: not an EXR tile (it changed since its header was read)");
        };
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
