//! Linear float images; sRGB PNG and compressed linear EXR encoding (with an optional alpha
//! channel and, for crops and tiles, the window's place in the full frame); writing that never
//! loses an output while reporting success; and reading tiles back for `stitch`.

use std::io::Write;
use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::render_record::RENDER_KEY;

/// Why an image could not be encoded, written or read back: one line naming the file (encoding
/// works in memory and names none). An I/O or codec cause is the `source()`, so a caller printing
/// the chain gets `FILE: cannot write: No space left on device (os error 28)`.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    /// The path's extension is neither `.png` nor `.exr`.
    #[error("{path}: unknown image extension (use .png or .exr)")]
    UnknownExtension {
        /// The output or tile path.
        path: PathBuf,
    },
    /// [`EncodeOptions::alpha`] has a length other than the pixel count.
    #[error("alpha has {alpha} values for {pixels} pixels")]
    AlphaLength {
        /// The number of alpha values.
        alpha: usize,
        /// The number of pixels.
        pixels: usize,
    },
    /// The PNG encoder failed.
    #[error("cannot encode PNG")]
    EncodePng(#[source] png::EncodingError),
    /// The EXR encoder failed.
    #[error("cannot encode EXR")]
    EncodeExr(#[source] exr::error::Error),
    /// The output path is a directory.
    #[error("{path}: is a directory")]
    IsDirectory {
        /// The output path.
        path: PathBuf,
    },
    /// A device or FIFO output does not open for writing.
    #[error("{path}: cannot open for writing")]
    Open {
        /// The output path.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// Writing, syncing or renaming the output failed (the old file, if any, is left as it was).
    #[error("{path}: cannot write")]
    Write {
        /// The output path.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// The encoded image is larger than the process may write (`ulimit -f`).
    #[error(
        "{path}: the image is {bytes} bytes, more than the file-size limit (ulimit -f) of {limit} bytes"
    )]
    FileSizeLimit {
        /// The output path.
        path: PathBuf,
        /// The encoded size.
        bytes: usize,
        /// The limit, in bytes.
        limit: u64,
    },
    /// `-o -` with stdout closed (`>&-`): the image would go nowhere.
    #[error("-: stdout is closed; the image would go nowhere (redirect it to a file or a pipe)")]
    StdoutClosed,
    /// The output's parent exists but is not a directory.
    #[error("{path}: {} is not a directory", .dir.display())]
    ParentNotADirectory {
        /// The output path.
        path: PathBuf,
        /// Its parent.
        dir: PathBuf,
    },
    /// The output's directory does not exist.
    #[error("{path}: directory {} does not exist", .dir.display())]
    NoDirectory {
        /// The output path.
        path: PathBuf,
        /// Its directory.
        dir: PathBuf,
    },
    /// No file can be created in the output's directory (the cause is part of the message).
    #[error("{path}: directory {} is not writable ({reason})", .dir.display())]
    DirectoryNotWritable {
        /// The output path.
        path: PathBuf,
        /// Its directory.
        dir: PathBuf,
        /// The error creating a probe file there.
        reason: std::io::Error,
    },
    /// A tile file does not open.
    #[error("{path}: cannot read")]
    Read {
        /// The tile path.
        path: PathBuf,
        /// Why.
        #[source]
        source: std::io::Error,
    },
    /// A tile is not a PNG the decoder can read.
    #[error("{path}: not a readable PNG")]
    DecodePng {
        /// The tile path.
        path: PathBuf,
        /// Why.
        #[source]
        source: png::DecodingError,
    },
    /// A tile's PNG is not 8-bit RGB or RGBA.
    #[error("{path}: {color:?} {depth:?} PNG is not an image phongrt writes (8-bit RGB/RGBA)")]
    UnsupportedPng {
        /// The tile path.
        path: PathBuf,
        /// Its colour type.
        color: png::ColorType,
        /// Its bit depth.
        depth: png::BitDepth,
    },
    /// A tile's `phongrt:window` text chunk does not parse as a [`Window`].
    #[error("{path}: malformed {WINDOW_KEY} {text:?}")]
    MalformedWindow {
        /// The tile path.
        path: PathBuf,
        /// The chunk's text.
        text: String,
    },
    /// A tile's PNG is too large for this machine's address space.
    #[error("PNG too large")]
    PngTooLarge,
    /// A tile is not an EXR the decoder can read.
    #[error("{path}: not a readable EXR")]
    DecodeExr {
        /// The tile path.
        path: PathBuf,
        /// Why.
        #[source]
        source: exr::error::Error,
    },
    /// A tile's EXR layer starts left of or above the frame.
    #[error("{path}: negative layer position")]
    NegativeLayerPosition {
        /// The tile path.
        path: PathBuf,
    },
    /// A tile's header differs from the one read when the tiles were checked.
    #[error("{path}: changed while being stitched")]
    Changed {
        /// The tile path.
        path: PathBuf,
    },
    /// A tile's recorded window is not its pixel size or not inside its frame.
    #[error("{path}: window {} does not match its {width}x{height} pixels", .window.to_text())]
    WindowSize {
        /// The tile path.
        path: PathBuf,
        /// The recorded window.
        window: Window,
        /// The tile's width in pixels.
        width: u32,
        /// The tile's height in pixels.
        height: u32,
    },
}

/// A linear-light RGB image, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` linear RGB values (unclamped), row by row from the top-left pixel:
    /// pixel `(x, y)` is at `y * width + x`.
    pub pixels: Vec<Vec3>,
}

/// The sRGB transfer function (IEC 61966-2-1), linear in `[0, 1]` to encoded `[0, 1]` (NaN
/// becomes 0, values outside are clamped).
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// One linear value as an 8-bit sRGB byte.
pub fn srgb8(c: f32) -> u8 {
    (linear_to_srgb(c) * 255.0 + 0.5) as u8
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Image { width, height, pixels: vec![Vec3::ZERO; width as usize * height as usize] }
    }

    /// The pixel at column `x`, row `y` (row 0 at the top). Panics outside the image.
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[(y as usize) * self.width as usize + x as usize]
    }

    /// Overwrite the pixel at column `x`, row `y` with `c`. Panics outside the image.
    pub fn set(&mut self, x: u32, y: u32, c: Vec3) {
        self.pixels[(y as usize) * self.width as usize + x as usize] = c;
    }

    /// 8-bit sRGB bytes, RGB interleaved.
    pub fn to_srgb8(&self) -> Vec<u8> {
        self.pixels.iter().flat_map(|c| c.to_array().map(srgb8)).collect()
    }

    /// Copy `other` into this image with its top-left corner at `(x0, y0)` (clipped).
    pub fn blit(&mut self, other: &Image, x0: u32, y0: u32) {
        for y in 0..other.height.min(self.height.saturating_sub(y0)) {
            for x in 0..other.width.min(self.width.saturating_sub(x0)) {
                self.set(x0 + x, y0 + y, other.get(x, y));
            }
        }
    }

    /// Write as sRGB PNG or compressed linear EXR, chosen by the extension, with
    /// [`write_atomically`]: the file at `path` is replaced only by a complete image.
    pub fn save(&self, path: &Path) -> Result<(), ImageError> {
        let format = ImageFormat::from_path(path)?;
        let bytes = encode(self, format, &EncodeOptions::default())?;
        write_atomically(path, &bytes)
    }
}

/// The image file formats written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// 8-bit sRGB PNG (RGB, or RGBA with straight alpha).
    Png,
    /// Linear 32-bit float OpenEXR, ZIP compressed (RGB, or RGBA with premultiplied alpha).
    Exr,
}

impl ImageFormat {
    /// The format named by a path's extension (`.png` or `.exr`, any case).
    pub fn from_path(path: &Path) -> Result<ImageFormat, ImageError> {
        let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
        match ext.as_deref() {
            Some("png") => Ok(ImageFormat::Png),
            Some("exr") => Ok(ImageFormat::Exr),
            _ => Err(ImageError::UnknownExtension { path: path.to_path_buf() }),
        }
    }
}

/// A crop window `[x0, x1) × [y0, y1)` of a `full_width × full_height` frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    /// First column of the window, in frame pixels.
    pub x0: u32,
    /// First row of the window (row 0 at the top of the frame).
    pub y0: u32,
    /// One past the last column: `x0 <= x1 <= full_width`.
    pub x1: u32,
    /// One past the last row: `y0 <= y1 <= full_height`.
    pub y1: u32,
    /// Width of the whole frame in pixels.
    pub full_width: u32,
    /// Height of the whole frame in pixels.
    pub full_height: u32,
}

/// The PNG text-chunk keyword that records a tile's [`Window`].
pub const WINDOW_KEY: &str = "phongrt:window";

impl Window {
    /// The whole frame.
    pub fn full(width: u32, height: u32) -> Window {
        Window { x0: 0, y0: 0, x1: width, y1: height, full_width: width, full_height: height }
    }

    /// The window's width in pixels, `x1 - x0` (0 for a window with `x1 < x0`, which no
    /// render or stitch accepts: the fields are public, so one can be built).
    pub fn width(&self) -> u32 {
        self.x1.saturating_sub(self.x0)
    }

    /// The window's height in pixels, `y1 - y0` (0 for a window with `y1 < y0`).
    pub fn height(&self) -> u32 {
        self.y1.saturating_sub(self.y0)
    }

    /// Whether the window is the whole frame (no crop).
    pub fn is_full(&self) -> bool {
        *self == Window::full(self.full_width, self.full_height)
    }

    /// Whether two windows share a pixel.
    pub fn overlaps(&self, o: &Window) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }

    /// `"X0,Y0,X1,Y1 of WxH"`, as stored in tile files and shown in messages.
    pub fn to_text(&self) -> String {
        format!("{},{},{},{} of {}x{}", self.x0, self.y0, self.x1, self.y1, self.full_width, self.full_height)
    }

    /// The inverse of [`Window::to_text`].
    pub fn from_text(s: &str) -> Option<Window> {
        let (b, full) = s.split_once(" of ")?;
        let (fw, fh) = full.split_once('x')?;
        let v: Vec<u32> = b.split(',').map(|t| t.trim().parse().ok()).collect::<Option<_>>()?;
        let w = Window {
            x0: *v.first()?,
            y0: *v.get(1)?,
            x1: *v.get(2)?,
            y1: *v.get(3)?,
            full_width: fw.parse().ok()?,
            full_height: fh.parse().ok()?,
        };
        (v.len() == 4 && w.x0 < w.x1 && w.y0 < w.y1 && w.x1 <= w.full_width && w.y1 <= w.full_height)
            .then_some(w)
    }
}

/// What goes into an image file besides the colours.
#[derive(Clone, Copy, Debug, Default)]
pub struct EncodeOptions<'a> {
    /// Coverage per pixel in [0, 1]; the colours are then premultiplied by it (as EXR expects),
    /// and PNG stores them divided back (straight alpha, as PNG expects).
    pub alpha: Option<&'a [f32]>,
    /// Where the image sits in its full frame (a crop or tile), recorded for `stitch`.
    pub window: Option<Window>,
    /// The render's [`RenderRecord`](crate::render_record::RenderRecord) text, recorded beside
    /// the window so that `stitch` can refuse tiles of another render.
    pub render: Option<&'a str>,
}

/// Encode an image in memory.
pub fn encode(img: &Image, format: ImageFormat, opts: &EncodeOptions) -> Result<Vec<u8>, ImageError> {
    if let Some(a) = opts.alpha.filter(|a| a.len() != img.pixels.len()) {
        return Err(ImageError::AlphaLength { alpha: a.len(), pixels: img.pixels.len() });
    }
    match format {
        ImageFormat::Png => {
            let channels = if opts.alpha.is_some() { 4 } else { 3 };
            let mut data = Vec::with_capacity(img.pixels.len() * channels);
            for (i, c) in img.pixels.iter().enumerate() {
                match opts.alpha {
                    None => data.extend(c.to_array().map(srgb8)),
                    Some(a) => {
                        let a = a[i].clamp(0.0, 1.0);
                        let straight = if a > 0.0 { *c / a } else { Vec3::ZERO };
                        data.extend(straight.to_array().map(srgb8));
                        data.push((a * 255.0 + 0.5) as u8);
                    }
                }
            }
            encode_png8(img.width, img.height, channels == 4, &data, opts.window, opts.render)
        }
        ImageFormat::Exr => encode_exr(img, opts),
    }
}

/// PNG from 8-bit sRGB bytes (RGB or RGBA interleaved), encoded as [`png_writer`] and
/// [`png::Writer::stream_writer`] do for `stitch`, so that a stitched frame is byte for byte the
/// whole render.
pub fn encode_png8(
    w: u32,
    h: u32,
    rgba: bool,
    data: &[u8],
    window: Option<Window>,
    render: Option<&str>,
) -> Result<Vec<u8>, ImageError> {
    let mut out = Vec::new();
    {
        let mut writer = png_writer(&mut out, w, h, rgba, window, render)?;
        let mut stream = writer.stream_writer().map_err(ImageError::EncodePng)?;
        stream.write_all(data).map_err(|e| ImageError::EncodePng(e.into()))?;
        stream.finish().map_err(ImageError::EncodePng)?;
        writer.finish().map_err(ImageError::EncodePng)?;
    }
    Ok(out)
}

/// A PNG writer with its header written: 8-bit sRGB, RGB or RGBA, and the tile's window and
/// render record as text chunks when given.
pub fn png_writer<W: Write>(
    sink: W,
    w: u32,
    h: u32,
    rgba: bool,
    window: Option<Window>,
    render: Option<&str>,
) -> Result<png::Writer<W>, ImageError> {
    let mut enc = png::Encoder::new(sink, w, h);
    enc.set_color(if rgba { png::ColorType::Rgba } else { png::ColorType::Rgb });
    enc.set_depth(png::BitDepth::Eight);
    enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    if let Some(win) = window {
        enc.add_text_chunk(WINDOW_KEY.to_string(), win.to_text()).map_err(ImageError::EncodePng)?;
    }
    if let Some(r) = render {
        enc.add_text_chunk(RENDER_KEY.to_string(), r.to_string()).map_err(ImageError::EncodePng)?;
    }
    enc.write_header().map_err(ImageError::EncodePng)
}

fn encode_exr(img: &Image, opts: &EncodeOptions) -> Result<Vec<u8>, ImageError> {
    use exr::prelude::*;
    let (w, h) = (img.width as usize, img.height as usize);
    let win = opts.window.unwrap_or(Window::full(img.width, img.height));
    let mut attrs = LayerAttributes::named("");
    attrs.layer_position = Vec2(win.x0 as i32, win.y0 as i32);
    attrs.software_name = Some(Text::from("phongrt"));
    if let Some(r) = opts.render {
        attrs.other.insert(Text::from(RENDER_KEY), AttributeValue::Text(Text::from(r)));
    }
    let mut buf = Vec::new();
    let px = |p: Vec2<usize>| img.pixels[p.y() * w + p.x()];
    let result = match opts.alpha {
        Some(alpha) => {
            let layer = Layer::new(
                (w, h),
                attrs,
                Encoding::SMALL_LOSSLESS,
                SpecificChannels::rgba(|p: Vec2<usize>| {
                    let (c, a) = (px(p), alpha[p.y() * w + p.x()]);
                    (c.x, c.y, c.z, a)
                }),
            );
            let mut image = exr::image::Image::from_layer(layer);
            image.attributes.display_window =
                IntegerBounds::new((0, 0), (win.full_width as usize, win.full_height as usize));
            image.write().to_buffered(std::io::Cursor::new(&mut buf))
        }
        None => {
            let layer = Layer::new(
                (w, h),
                attrs,
                Encoding::SMALL_LOSSLESS,
                SpecificChannels::rgb(|p: Vec2<usize>| {
                    let c = px(p);
                    (c.x, c.y, c.z)
                }),
            );
            let mut image = exr::image::Image::from_layer(layer);
            image.attributes.display_window =
                IntegerBounds::new((0, 0), (win.full_width as usize, win.full_height as usize));
            image.write().to_buffered(std::io::Cursor::new(&mut buf))
        }
    };
    result.map_err(ImageError::EncodeExr)?;
    Ok(buf)
}

/// The file-size limit of this process (`ulimit -f`), in bytes, where the system says.
fn file_size_limit() -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = limits.lines().find(|l| l.starts_with("Max file size"))?;
    line.split_whitespace().nth(3)?.parse().ok()
}

/// Whether stdout was closed when the process started (`phongrt render ... -o - >&-`). std then
/// opens `/dev/null` read-write as fd 1, so that writes succeed and the bytes go nowhere; a
/// shell's `> /dev/null` opens it write-only. So fd 1 being `/dev/null` (same device and inode)
/// with the read-write access mode (`/proc/self/fdinfo/1`) means it was closed.
pub fn stdout_is_closed() -> bool {
    use std::os::unix::fs::MetadataExt;
    let (Ok(fd1), Ok(null)) = (std::fs::metadata("/proc/self/fd/1"), std::fs::metadata("/dev/null")) else {
        return false;
    };
    if (fd1.dev(), fd1.ino()) != (null.dev(), null.ino()) {
        return false;
    }
    let Ok(info) = std::fs::read_to_string("/proc/self/fdinfo/1") else {
        return false;
    };
    let flags = info.lines().find_map(|l| l.strip_prefix("flags:")).map(str::trim);
    // O_ACCMODE is 3, O_RDWR 2 (octal in fdinfo).
    flags.and_then(|f| u32::from_str_radix(f, 8).ok()).is_some_and(|f| f & 3 == 2)
}

/// Write `bytes` to stdout, every write checked. A closed stdout is an error (std would drop
/// the bytes without one, see [`stdout_is_closed`]), and so is a regular file that the bytes
/// would take past the file-size limit (`ulimit -f`), which would otherwise kill the process
/// with SIGXFSZ halfway.
pub fn write_stdout(bytes: &[u8]) -> Result<(), ImageError> {
    use std::io::Seek;
    use std::os::fd::AsFd;
    let path = || PathBuf::from("-");
    if stdout_is_closed() {
        return Err(ImageError::StdoutClosed);
    }
    let stdout = std::io::stdout();
    let dup =
        stdout.as_fd().try_clone_to_owned().map_err(|source| ImageError::Open { path: path(), source })?;
    let mut file = std::fs::File::from(dup);
    if file.metadata().is_ok_and(|m| m.is_file()) {
        let at = file.stream_position().unwrap_or(0);
        if let Some(limit) = file_size_limit().filter(|&l| at + bytes.len() as u64 > l) {
            return Err(ImageError::FileSizeLimit { path: path(), bytes: bytes.len(), limit });
        }
    }
    let mut out = stdout.lock();
    let write_error = |source| ImageError::Write { path: path(), source };
    out.write_all(bytes).map_err(write_error)?;
    out.flush().map_err(write_error)
}

/// Write `bytes` to `path` so that either the whole file is there or an error is returned:
/// a regular file (or a new one) is written to a temporary file in the same directory, every
/// write and the final sync checked, then renamed over `path`. A path that is not a regular
/// file (a device such as `/dev/stdout` or `/dev/full`, a FIFO) is written directly, every write
/// and the flush checked. An image larger than the file-size limit (`ulimit -f`) is refused
/// before anything is written.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), ImageError> {
    let path_buf = || path.to_path_buf();
    let write_error = |source| ImageError::Write { path: path_buf(), source };
    // Follow a symlink to where the bytes will really go.
    let target: PathBuf = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    let meta = std::fs::metadata(&target).ok();
    if meta.as_ref().is_some_and(|m| m.is_dir()) {
        return Err(ImageError::IsDirectory { path: path_buf() });
    }
    if meta.as_ref().is_some_and(|m| !m.is_file()) {
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .open(&target)
            .map_err(|source| ImageError::Open { path: path_buf(), source })?;
        f.write_all(bytes).map_err(write_error)?;
        f.flush().map_err(write_error)?;
        return Ok(());
    }
    if let Some(limit) = file_size_limit().filter(|&l| bytes.len() as u64 > l) {
        return Err(ImageError::FileSizeLimit { path: path_buf(), bytes: bytes.len(), limit });
    }
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let file_name = target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    // A name no other process (on any host, in any PID namespace) uses: only this one's to
    // remove on failure (when it drops) or on a signal.
    let mut tmp = super::temp_file::TempFile::create(&dir, &file_name).map_err(write_error)?;
    tmp.file().write_all(bytes).and_then(|()| tmp.file().sync_all()).map_err(write_error)?;
    tmp.persist(&target).map_err(write_error)
}

/// Check, before any work, that an image can be written at `path`: a known extension, an
/// existing directory in which a file can be created (tried), and not a directory itself.
pub fn check_writable(path: &Path) -> Result<ImageFormat, ImageError> {
    let format = ImageFormat::from_path(path)?;
    let path_buf = || path.to_path_buf();
    if std::fs::metadata(path).is_ok_and(|m| m.is_dir()) {
        return Err(ImageError::IsDirectory { path: path_buf() });
    }
    let target: PathBuf = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
    if std::fs::metadata(&target).is_ok_and(|m| !m.is_file()) {
        // A device or FIFO: writable if it opens for writing.
        std::fs::OpenOptions::new()
            .write(true)
            .open(&target)
            .map_err(|source| ImageError::Open { path: path_buf(), source })?;
        return Ok(format);
    }
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    match std::fs::metadata(&dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => return Err(ImageError::ParentNotADirectory { path: path_buf(), dir }),
        Err(_) => return Err(ImageError::NoDirectory { path: path_buf(), dir }),
    }
    // The probe file is removed when it drops.
    if let Err(reason) = super::temp_file::TempFile::create(&dir, "phongrt-probe") {
        return Err(ImageError::DirectoryNotWritable { path: path_buf(), dir, reason });
    }
    Ok(format)
}

/// Pixels read back from an image file: 8-bit sRGB from PNG, linear floats from EXR.
#[derive(Clone, Debug, PartialEq)]
pub enum TilePixels {
    /// Interleaved bytes, `channels` (3 or 4) per pixel.
    Srgb8 {
        /// 3 for RGB, 4 for RGBA (straight alpha).
        channels: usize,
        /// The sRGB-encoded samples, row by row from the top-left pixel.
        data: Vec<u8>,
    },
    /// Interleaved floats, `channels` (3 or 4) per pixel.
    Linear {
        /// 3 for RGB, 4 for RGBA (premultiplied alpha).
        channels: usize,
        /// The linear samples, row by row from the top-left pixel.
        data: Vec<f32>,
    },
}

/// An image file read back with its window (a whole frame when it records none).
#[derive(Clone, Debug, PartialEq)]
pub struct Tile {
    /// Where the pixels sit in the full frame (the whole image when the file records none).
    pub window: Window,
    /// The file's pixels, `window.width() * window.height()` of them.
    pub pixels: TilePixels,
    /// Whether the file recorded a window (PNG text chunk, or an EXR display window).
    pub has_window: bool,
    /// The recorded [`RenderRecord`](crate::render_record::RenderRecord) text (none in tiles
    /// written before it was recorded).
    pub render: Option<String>,
}

/// What a tile file says about itself before its pixels are read: enough to check a set of
/// tiles (and the memory a stitch needs) without decoding any.
#[derive(Clone, Debug, PartialEq)]
pub struct TileHeader {
    /// Where the tile sits in its frame (the whole frame when it records none).
    pub window: Window,
    /// Whether the file recorded a window (PNG text chunk, or an EXR display window).
    pub has_window: bool,
    /// The recorded [`RenderRecord`](crate::render_record::RenderRecord) text, if any.
    pub render: Option<String>,
    /// PNG (8-bit sRGB) or EXR (linear floats).
    pub format: ImageFormat,
    /// 3 (RGB) or 4 (RGBA).
    pub channels: usize,
}

/// A PNG tile opened and its header read and checked: the decoder is ready for its rows.
pub type PngReader = png::Reader<std::io::BufReader<std::fs::File>>;

/// Open a PNG tile: its header, and the decoder positioned at its first row (8-bit RGB or RGBA,
/// not interlaced, as `phongrt render` writes).
pub fn open_png_tile(path: &Path) -> Result<(TileHeader, PngReader), ImageError> {
    let path_buf = || path.to_path_buf();
    let png_error = |source| ImageError::DecodePng { path: path_buf(), source };
    let f = std::fs::File::open(path).map_err(|source| ImageError::Read { path: path_buf(), source })?;
    let mut dec = png::Decoder::new(std::io::BufReader::new(f));
    dec.set_transformations(png::Transformations::IDENTITY);
    let reader = dec.read_info().map_err(png_error)?;
    let info = reader.info();
    let (w, h) = (info.width, info.height);
    let channels = match (info.color_type, info.bit_depth, info.interlaced) {
        (png::ColorType::Rgb, png::BitDepth::Eight, false) => 3,
        (png::ColorType::Rgba, png::BitDepth::Eight, false) => 4,
        (color, depth, _) => return Err(ImageError::UnsupportedPng { path: path_buf(), color, depth }),
    };
    let text = info.uncompressed_latin1_text.iter().find(|t| t.keyword == WINDOW_KEY);
    let (window, has_window) = match text {
        Some(t) => (
            Window::from_text(&t.text)
                .ok_or_else(|| ImageError::MalformedWindow { path: path_buf(), text: t.text.clone() })?,
            true,
        ),
        None => (Window::full(w, h), false),
    };
    let render = info.uncompressed_latin1_text.iter().find(|t| t.keyword == RENDER_KEY);
    let render = render.map(|t| t.text.clone());
    check_size(path, &window, w, h)?;
    let header = TileHeader { window, has_window, render, format: ImageFormat::Png, channels };
    Ok((header, reader))
}

/// Read a tile's header only (no pixels): a PNG's chunks before its image data, an EXR's header.
pub fn read_tile_header(path: &Path) -> Result<TileHeader, ImageError> {
    match ImageFormat::from_path(path)? {
        ImageFormat::Png => Ok(open_png_tile(path)?.0),
        ImageFormat::Exr => {
            use exr::prelude::*;
            let decode_error = |source| ImageError::DecodeExr { path: path.to_path_buf(), source };
            let meta = exr::meta::MetaData::read_from_file(path, false).map_err(decode_error)?;
            let header = meta
                .headers
                .first()
                .ok_or_else(|| decode_error(exr::error::Error::Invalid("no layer".into())))?;
            let pos = header.own_attributes.layer_position;
            if pos.x() < 0 || pos.y() < 0 {
                return Err(ImageError::NegativeLayerPosition { path: path.to_path_buf() });
            }
            let (res, disp) = (header.layer_size, header.shared_attributes.display_window);
            let window = exr_window(pos, res, disp.size);
            let render = match header.own_attributes.other.get(&Text::from(RENDER_KEY)) {
                Some(AttributeValue::Text(t)) => Some(t.to_string()),
                _ => None,
            };
            let has_alpha = header.channels.list.iter().any(|c| c.name == *"A");
            check_size(path, &window, res.x() as u32, res.y() as u32)?;
            let channels = if has_alpha { 4 } else { 3 };
            Ok(TileHeader {
                window,
                has_window: !window.is_full(),
                render,
                format: ImageFormat::Exr,
                channels,
            })
        }
    }
}

/// An EXR layer's window in its display window.
fn exr_window(
    pos: exr::math::Vec2<i32>,
    res: exr::math::Vec2<usize>,
    full: exr::math::Vec2<usize>,
) -> Window {
    let (x0, y0) = (pos.x() as u32, pos.y() as u32);
    Window {
        x0,
        y0,
        x1: x0 + res.x() as u32,
        y1: y0 + res.y() as u32,
        full_width: full.x() as u32,
        full_height: full.y() as u32,
    }
}

/// Read a PNG or EXR written by `phongrt render` (any crop or tile of it).
pub fn read_tile(path: &Path) -> Result<Tile, ImageError> {
    let path_buf = || path.to_path_buf();
    match ImageFormat::from_path(path)? {
        ImageFormat::Png => {
            let (header, mut reader) = open_png_tile(path)?;
            let (w, h) = (header.window.width(), header.window.height());
            let mut data = vec![0u8; reader.output_buffer_size().ok_or(ImageError::PngTooLarge)?];
            reader
                .next_frame(&mut data)
                .map_err(|source| ImageError::DecodePng { path: path_buf(), source })?;
            data.truncate(w as usize * h as usize * header.channels);
            let TileHeader { window, has_window, render, channels, .. } = header;
            Ok(Tile { window, pixels: TilePixels::Srgb8 { channels, data }, has_window, render })
        }
        ImageFormat::Exr => {
            use exr::prelude::*;
            let img = read()
                .no_deep_data()
                .largest_resolution_level()
                .rgba_channels(
                    |res, ch: &RgbaChannels| (res, ch.3.is_some(), vec![0f32; res.area() * 4]),
                    |(res, _, buf): &mut (Vec2<usize>, bool, Vec<f32>),
                     p: Vec2<usize>,
                     (r, g, b, a): (f32, f32, f32, f32)| {
                        let i = (p.y() * res.x() + p.x()) * 4;
                        buf[i..i + 4].copy_from_slice(&[r, g, b, a]);
                    },
                )
                .first_valid_layer()
                .all_attributes()
                .from_file(path)
                .map_err(|source| ImageError::DecodeExr { path: path_buf(), source })?;
            let layer = &img.layer_data;
            let (res, has_alpha, buf) = &layer.channel_data.pixels;
            let pos = layer.attributes.layer_position;
            if pos.x() < 0 || pos.y() < 0 {
                return Err(ImageError::NegativeLayerPosition { path: path_buf() });
            }
            let window = exr_window(pos, *res, img.attributes.display_window.size);
            let render = match layer.attributes.other.get(&Text::from(RENDER_KEY)) {
                Some(AttributeValue::Text(t)) => Some(t.to_string()),
                _ => None,
            };
            let channels = if *has_alpha { 4 } else { 3 };
            let data: Vec<f32> = if *has_alpha {
                buf.clone()
            } else {
                buf.chunks_exact(4).flat_map(|c| [c[0], c[1], c[2]]).collect()
            };
            check_size(path, &window, res.x() as u32, res.y() as u32)?;
            let has_window = !window.is_full();
            Ok(Tile { window, pixels: TilePixels::Linear { channels, data }, has_window, render })
        }
    }
}

fn check_size(path: &Path, win: &Window, w: u32, h: u32) -> Result<(), ImageError> {
    if win.width() == w && win.height() == h && win.x1 <= win.full_width && win.y1 <= win.full_height {
        return Ok(());
    }
    Err(ImageError::WindowSize { path: path.to_path_buf(), window: *win, width: w, height: h })
}

#[cfg(test)]
mod tests {
    use super::Window;

    #[test]
    fn window_text_round_trips_and_refuses_inverted_windows() {
        let w = Window { x0: 2, y0: 3, x1: 10, y1: 7, full_width: 16, full_height: 8 };
        assert_eq!(Window::from_text(&w.to_text()), Some(w));
        assert_eq!(Window::from_text("10,3,2,7 of 16x8"), None);
        assert_eq!(Window::from_text("2,3,10,9 of 16x8"), None);
    }

    #[test]
    fn inverted_window_has_zero_size_instead_of_wrapping() {
        let w = Window { x0: 10, y0: 7, x1: 2, y1: 3, full_width: 16, full_height: 8 };
        assert_eq!((w.width(), w.height()), (0, 0));
    }
}
