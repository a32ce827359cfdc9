//! Tiles (`render --tile` or `--crop` outputs) assembled into one image: every pixel covered
//! exactly once, all of one frame size, one kind and one render.

use std::path::{Path, PathBuf};

use crate::image_out::{self, ImageError, ImageFormat, TileHeader};
use crate::render_record::{RenderRecord, RENDER_KEY};
use crate::Window;

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
/// before any pixel is read: a tile claiming a huge size costs nothing. Tiles are streamed into
/// the output, PNG row by row and EXR block by block (memory: a few rows, whatever the frame's
/// height); a stitch whose rows alone need more than the memory budget ([`memory_budget`]) is
/// refused.
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
        (ImageFormat::Exr, _) => stream_exr(output, tiles, &headers)?,
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

/// Bytes a stitch of these (checked) tiles needs, estimated from their headers; both formats
/// are streamed, so it grows with the frame's width and the tiles' widths, not the frame's area.
/// - PNG: the output row and, per tile open at once (crossing one row), its decoder (two rows, the inflate window and the read
///   buffer) and the encoder's deflate state.
/// - EXR: the output block of 16 rows three times over (the rows, the block, its compression)
///   and, per tile open at once, up to two of its decoded blocks (32 rows at most each) and the read buffer.
pub fn stitch_memory(headers: &[(String, TileHeader)]) -> u64 {
    let first = &headers[0].1;
    let (fw, ch) = (first.window.full_width as u64, first.channels as u64);
    // Compute the most any row has open: the tiles crossing the first row of each tile.
    let tiles = |row_bytes: u64, rows: u64, fixed: u64| -> u64 {
        let open_at = |y: u32| -> u64 {
            let crossing = headers.iter().filter(|(_, h)| (h.window.y0..h.window.y1).contains(&y));
            crossing.map(|(_, h)| h.window.width() as u64 * row_bytes * rows + fixed).sum()
        };
        headers.iter().map(|(_, h)| open_at(h.window.y0)).max().unwrap_or(0)
    };
    match first.format {
        ImageFormat::Png => fw * ch * 2 + tiles(ch, 2, 96 << 10) + (1 << 20),
        ImageFormat::Exr => fw * ch * 4 * 16 * 3 + tiles(ch * 4, 64, 96 << 10) + (1 << 20),
    }
}

/// Refuse a stitch that needs more than `budget` bytes.
fn check_memory(headers: &[(String, TileHeader)], budget: Option<u64>) -> Result<(), StitchError> {
    let need = stitch_memory(headers);
    let Some(budget) = budget.filter(|&b| need > b) else {
        return Ok(());
    };
    let w = &headers[0].1.window;
    let gb = |b: u64| match b {
        b if b >= 1 << 30 => format!("{:.2} GB", b as f64 / 1e9),
        b => format!("{:.1} MB", b as f64 / 1e6),
    };
    refuse!(
        "the {}x{} frame needs about {} in memory, more than the {} allowed (PHONGRT_MAX_MEMORY, or \
         MemAvailable), streaming rows",
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
    let (target, mut tmp) = output_temp(output)?;
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

/// The file `output` really names (through links) and a new temp file beside it, to be
/// persisted onto it once complete.
fn output_temp(output: &Path) -> Result<(PathBuf, crate::temp_file::TempFile), ImageError> {
    let out_error = |source| ImageError::Write { path: output.to_path_buf(), source };
    let target = std::fs::canonicalize(output).unwrap_or_else(|_| output.to_path_buf());
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = crate::temp_file::TempFile::create(&dir, &name).map_err(out_error)?;
    Ok((target, tmp))
}

/// Stream EXR tiles into `output` one block of rows at a time (ZIP, 16 rows a block, increasing
/// line order): each block's rows are put together from the tiles that cross them, each tile
/// decoded block by block as its rows are needed (opened at its first row, dropped after its
/// last), so memory stays at a few blocks of rows whatever the frame's size.
fn stream_exr(output: &Path, tiles: &[PathBuf], headers: &[(String, TileHeader)]) -> Result<(), ImageError> {
    use exr::block::writer::ChunksWriter;
    use exr::prelude::*;
    use std::io::Write;
    let first = &headers[0].1;
    let (fw, fh, ch) = (first.window.full_width, first.window.full_height, first.channels);
    let out_error = |source| ImageError::Write { path: output.to_path_buf(), source };
    let (target, mut tmp) = output_temp(output)?;

    // Compute the output's header: the frame, RGB(A) f32, as `render` writes a whole frame.
    let names: &[&str] = if ch == 4 { &["A", "B", "G", "R"] } else { &["B", "G", "R"] };
    let channels = names.iter().map(|n| ChannelDescription::new(*n, SampleType::F32, true)).collect();
    let mut header = exr::meta::header::Header::new(Text::from(""), (fw as usize, fh as usize), channels)
        .with_encoding(Compression::ZIP16, exr::meta::BlockDescription::ScanLines, LineOrder::Increasing);
    header.own_attributes.software_name = Some(Text::from("phongrt"));
    let out_channels = header.channels.clone();

    // Write the blocks in order, each from the tiles' rows; a failure to read a tile is kept
    // aside and returned once the writer has stopped.
    let mut failure: Option<ImageError> = None;
    let mut rows = ExrRowSource::new(tiles, headers);
    let mut sink = std::io::BufWriter::new(tmp.file());
    let written = exr::block::write(&mut sink, SmallVec::from_elem(header, 1), true, |meta, chunks| {
        let mut compressor = chunks.sequential_blocks_compressor(&meta);
        for (index, block) in meta.enumerate_ordered_header_block_indices() {
            let (y0, n) = (block.pixel_position.y() as u32, block.pixel_size.y() as u32);
            let frame_rows = match rows.rows(y0, n) {
                Ok(r) => r,
                Err(e) => {
                    failure = Some(e);
                    return Err(exr::error::Error::Aborted);
                }
            };
            let data = exr::block::UncompressedBlock::from_lines(&out_channels, block, |line| {
                // The output's channels are named in order A, B, G, R (or B, G, R): slots 3, 2, 1, 0.
                let slot = ch - 1 - line.location.channel;
                // Block positions are the frame's (the output's data window starts at 0, 0).
                let r = line.location.position.y() - y0 as usize;
                let row = &frame_rows[r * fw as usize * ch..];
                let _ = line.write_samples(|x| row[x * ch + slot]);
            });
            compressor.compress_block(index, data)?;
        }
        Ok(())
    });
    if let Some(e) = failure {
        return Err(e);
    }
    written.map_err(ImageError::EncodeExr)?;
    sink.flush().map_err(out_error)?;
    drop(sink);
    tmp.file().sync_all().map_err(out_error)?;
    tmp.persist(&target).map_err(out_error)
}

/// The frame's rows, top to bottom, from EXR tiles read block by block.
struct ExrRowSource<'a> {
    tiles: &'a [PathBuf],
    headers: &'a [(String, TileHeader)],
    /// The tiles by their first row, not yet opened.
    order: Vec<usize>,
    next: usize,
    open: Vec<ExrTileRows>,
    /// The frame's channels per pixel (3 or 4).
    ch: usize,
    width: usize,
}

/// One EXR tile being read block by block: its decoded rows not yet used, by frame row.
struct ExrTileRows {
    tile: usize,
    blocks: exr::block::reader::SequentialBlockDecompressor<
        exr::block::reader::AllChunksReader<std::io::BufReader<std::fs::File>>,
    >,
    /// Each of the tile's channels' slot in an RGBA pixel (R 0, G 1, B 2, A 3).
    slots: Vec<usize>,
    rows: std::collections::BTreeMap<u32, Vec<f32>>,
}

impl<'a> ExrRowSource<'a> {
    fn new(tiles: &'a [PathBuf], headers: &'a [(String, TileHeader)]) -> Self {
        let mut order: Vec<usize> = (0..headers.len()).collect();
        order.sort_by_key(|&i| (headers[i].1.window.y0, headers[i].1.window.x0));
        let first = &headers[0].1;
        ExrRowSource {
            tiles,
            headers,
            order,
            next: 0,
            open: Vec::new(),
            ch: first.channels,
            width: first.window.full_width as usize,
        }
    }

    /// Frame rows `y0..y0 + n`, RGB(A) f32 interleaved, row after row.
    fn rows(&mut self, y0: u32, n: u32) -> Result<Vec<f32>, ImageError> {
        let (w, ch) = (self.width, self.ch);
        let mut out = vec![0f32; w * ch * n as usize];
        for y in y0..y0 + n {
            self.open_tiles_at(y)?;
            let row = &mut out[(y - y0) as usize * w * ch..][..w * ch];
            for t in &mut self.open {
                let win = &self.headers[t.tile].1.window;
                let src = t.row(y, &self.tiles[t.tile], win)?;
                let at = win.x0 as usize * ch;
                row[at..at + src.len()].copy_from_slice(&src);
            }
            let headers = self.headers;
            self.open.retain(|t| headers[t.tile].1.window.y1 > y + 1);
        }
        Ok(out)
    }

    /// Open the tiles whose first row is `y`, checking they are still what their headers said.
    fn open_tiles_at(&mut self, y: u32) -> Result<(), ImageError> {
        while let Some(&i) = self.order.get(self.next).filter(|&&i| self.headers[i].1.window.y0 == y) {
            let path = &self.tiles[i];
            if image_out::read_tile_header(path)? != self.headers[i].1 {
                return Err(ImageError::Changed { path: path.clone() });
            }
            self.open.push(ExrTileRows::open(i, path, self.ch)?);
            self.next += 1;
        }
        Ok(())
    }
}

impl ExrTileRows {
    fn open(tile: usize, path: &Path, ch: usize) -> Result<Self, ImageError> {
        use exr::block::reader::ChunksReader;
        let decode_error = |source| ImageError::DecodeExr { path: path.to_path_buf(), source };
        let file = std::fs::File::open(path).map_err(|e| decode_error(exr::error::Error::from(e)))?;
        let reader = exr::block::read(std::io::BufReader::new(file), true).map_err(decode_error)?;
        let slots = reader.headers()[0]
            .channels
            .list
            .iter()
            .map(|c| match c.name.to_string().as_str() {
                "R" => 0,
                "G" => 1,
                "B" => 2,
                "A" if ch == 4 => 3,
                _ => usize::MAX,
            })
            .collect();
        let blocks = reader.all_chunks(true).map_err(decode_error)?.sequential_decompressor(true);
        Ok(ExrTileRows { tile, blocks, slots, rows: Default::default() })
    }

    /// The tile's part of frame row `y` (its window's width x `ch` floats), decoding blocks until
    /// it is there.
    fn row(&mut self, y: u32, path: &Path, win: &Window) -> Result<Vec<f32>, ImageError> {
        let decode_error = |source| ImageError::DecodeExr { path: path.to_path_buf(), source };
        let ch = if self.slots.contains(&3) { 4 } else { 3 };
        while !self.rows.contains_key(&y) {
            let Some(block) = self.blocks.decompress_next_block() else {
                return Err(decode_error(exr::error::Error::from(truncated())));
            };
            let block = block.map_err(decode_error)?;
            let channels = &self.blocks.meta_data().headers[0].channels;
            for line in block.lines(channels) {
                let fy = win.y0 + line.location.position.y() as u32;
                let slot = self.slots[line.location.channel];
                let row = self.rows.entry(fy).or_insert_with(|| vec![0f32; win.width() as usize * ch]);
                if slot == usize::MAX {
                    continue;
                }
                for (x, v) in line.read_samples::<f32>().enumerate() {
                    row[x * ch + slot] = v.map_err(decode_error)?;
                }
            }
        }
        Ok(self.rows.remove(&y).unwrap_or_default())
    }
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
