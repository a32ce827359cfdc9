//! Image textures for `map_Kd`: decoded once to linear RGB (sRGB decode), sampled with bilinear
//! filtering and repeat wrapping.

use std::path::Path;

use glam::{Vec2, Vec3};

/// A linear-RGB texture.
#[derive(Clone, Debug)]
pub struct Texture {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    texels: Vec<Vec3>,
}

/// The sRGB transfer function's inverse (IEC 61966-2-1).
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Decode an image file that is a regular file (after following links): a FIFO, device or
/// directory is refused before it is opened, and the open uses `O_NONBLOCK`, so a path swapped
/// for a FIFO in between cannot block either (what was opened is checked again). The format
/// comes from the extension, or from the contents when the extension names none.
pub fn decode_regular_file(path: &Path) -> Result<image::DynamicImage, String> {
    use std::os::unix::fs::OpenOptionsExt;
    let not_regular = |m: &std::fs::Metadata| !m.is_file();
    let meta = std::fs::metadata(path).map_err(|e| format!("cannot read: {e}"))?;
    if not_regular(&meta) {
        return Err("not a regular file".into());
    }
    let file = std::fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(path)
        .map_err(|e| format!("cannot read: {e}"))?;
    if file.metadata().map_or(true, |m| not_regular(&m)) {
        return Err("not a regular file".into());
    }
    let reader = std::io::BufReader::new(file);
    let reader = match image::ImageFormat::from_path(path) {
        Ok(format) => image::ImageReader::with_format(reader, format),
        Err(_) => image::ImageReader::new(reader).with_guessed_format().map_err(|e| e.to_string())?,
    };
    reader.decode().map_err(|e| e.to_string())
}

impl Texture {
    /// Read an 8-bit image file as sRGB. Errors are one line naming the file.
    pub fn load(path: &Path) -> Result<Texture, String> {
        let img = decode_regular_file(path)
            .map_err(|e| format!("{}: cannot decode texture: {e}", path.display()))?;
        let rgb = img.to_rgb8();
        let lut: Vec<f32> = (0..256).map(|i| srgb_to_linear(i as f32 / 255.0)).collect();
        let texels =
            rgb.pixels().map(|p| Vec3::new(lut[p[0] as usize], lut[p[1] as usize], lut[p[2] as usize]));
        Texture::from_linear(rgb.width(), rgb.height(), texels.collect())
            .ok_or_else(|| format!("{}: texture has no pixels", path.display()))
    }

    /// A texture from linear texels, row by row from the top; `None` for an empty or
    /// wrong-sized array.
    pub fn from_linear(width: u32, height: u32, texels: Vec<Vec3>) -> Option<Texture> {
        (width > 0 && height > 0 && texels.len() == width as usize * height as usize).then_some(Texture {
            width,
            height,
            texels,
        })
    }

    fn texel(&self, x: i64, y: i64) -> Vec3 {
        let (w, h) = (self.width as i64, self.height as i64);
        self.texels[(y.rem_euclid(h) * w + x.rem_euclid(w)) as usize]
    }

    /// Bilinear lookup for a latitude-longitude map: `u` wraps around, `t` in [0, 1] runs from
    /// the top row (0) to the bottom row (1) and is clamped there (no wrap over the poles).
    pub fn sample_latlong(&self, u: f32, t: f32) -> Vec3 {
        let (u, t) =
            (if u.is_finite() { u } else { 0.0 }, if t.is_finite() { t.clamp(0.0, 1.0) } else { 0.0 });
        let x = (u - u.floor()) * self.width as f32 - 0.5;
        let y = (t * self.height as f32 - 0.5).clamp(0.0, (self.height - 1) as f32);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let y1 = (y0 + 1).min(self.height as i64 - 1);
        let top = self.texel(x0, y0).lerp(self.texel(x0 + 1, y0), fx);
        let bottom = self.texel(x0, y1).lerp(self.texel(x0 + 1, y1), fx);
        top.lerp(bottom, fy)
    }

    /// Bilinear lookup at `uv` (OBJ convention: `v` = 0 at the bottom row), wrapping by repeat.
    /// A non-finite `uv` gives the texel at (0, 0).
    pub fn sample(&self, uv: Vec2) -> Vec3 {
        let uv = if uv.is_finite() { uv } else { Vec2::ZERO };
        let x = (uv.x - uv.x.floor()) * self.width as f32 - 0.5;
        let y = (1.0 - (uv.y - uv.y.floor())) * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = self.texel(x0, y0).lerp(self.texel(x0 + 1, y0), fx);
        let bottom = self.texel(x0, y0 + 1).lerp(self.texel(x0 + 1, y0 + 1), fx);
        top.lerp(bottom, fy)
    }
}
