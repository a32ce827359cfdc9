//! Linear float images, sRGB PNG and linear EXR output.

use std::path::Path;

use glam::Vec3;

use super::RenderError;

/// A linear-light RGB image, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Vec3>,
}

/// The sRGB transfer function (IEC 61966-2-1), linear in [0,1] to encoded [0,1].
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        Image { width, height, pixels: vec![Vec3::ZERO; width as usize * height as usize] }
    }

    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[(y * self.width + x) as usize]
    }

    pub fn set(&mut self, x: u32, y: u32, c: Vec3) {
        self.pixels[(y * self.width + x) as usize] = c;
    }

    /// 8-bit sRGB bytes, RGB interleaved.
    pub fn to_srgb8(&self) -> Vec<u8> {
        self.pixels
            .iter()
            .flat_map(|c| c.to_array().map(|x| (linear_to_srgb(x) * 255.0 + 0.5) as u8))
            .collect()
    }

    /// Copy `other` into this image with its top-left corner at `(x0, y0)` (clipped).
    pub fn blit(&mut self, other: &Image, x0: u32, y0: u32) {
        for y in 0..other.height.min(self.height.saturating_sub(y0)) {
            for x in 0..other.width.min(self.width.saturating_sub(x0)) {
                self.set(x0 + x, y0 + y, other.get(x, y));
            }
        }
    }

    /// Write as sRGB PNG or linear EXR, chosen by the extension.
    pub fn save(&self, path: &Path) -> Result<(), RenderError> {
        let ext = path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase());
        let write = |format: &'static str| {
            move |source| RenderError::ImageWrite { path: path.to_path_buf(), format, source }
        };
        // A pixel buffer whose length does not match the size (the fields are public).
        let mismatch = |format: &'static str| {
            write(format)(image::ImageError::Parameter(image::error::ParameterError::from_kind(
                image::error::ParameterErrorKind::DimensionMismatch,
            )))
        };
        match ext.as_deref() {
            Some("png") => {
                let img = image::RgbImage::from_raw(self.width, self.height, self.to_srgb8())
                    .ok_or_else(|| mismatch("PNG"))?;
                img.save_with_format(path, image::ImageFormat::Png).map_err(write("PNG"))?;
            }
            Some("exr") => {
                let data: Vec<f32> = self.pixels.iter().flat_map(|c| c.to_array()).collect();
                let img = image::Rgb32FImage::from_raw(self.width, self.height, data)
                    .ok_or_else(|| mismatch("EXR"))?;
                img.save_with_format(path, image::ImageFormat::OpenExr).map_err(write("EXR"))?;
            }
            _ => return Err(RenderError::ImageExtension { path: path.to_path_buf() }),
        }
        Ok(())
    }
}
