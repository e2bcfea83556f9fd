//! Decoding an image's pixels to RGBA8 for display.
//!
//! TIFF goes through the `tiff` crate, PNG through `png`, JPEG through `zune-jpeg`. The TIFF
//! conversion rules, per photometric interpretation:
//!
//! * BlackIsZero / WhiteIsZero (grey): one grey sample, shown as R = G = B. WhiteIsZero is
//!   **photometrically corrected** (the `tiff` crate inverts it), so a stored 255 shows black:
//!   the RGBA is what the image looks like, not the raw samples. A following alpha extra sample
//!   becomes A.
//! * RGB: the first three samples; a fourth becomes A only when `ExtraSamples` says it is
//!   alpha (associated or not); other extra bands (a NAIP near-infrared band) are ignored.
//! * Palette: the index is looked up in `ColorMap` (16-bit entries scaled to 8 bits, rounded).
//!   The `tiff` crate 0.11 does not decode palette images, so the file is decoded as grey after
//!   its PhotometricInterpretation entry is rewritten to BlackIsZero in an in-memory copy; the
//!   grey values are then the indices.
//! * Both chunky and planar (`PlanarConfiguration` 2) layouts; 1-, 2-, 4-, 8- and 16-bit unsigned
//!   samples, 16-bit ones scaled to 8 bits (`v·255/65535`, rounded), sub-byte grey scaled to
//!   the full range.
//!
//! Alpha is 255 unless the image has an alpha channel; GDAL's nodata value is not applied.

use std::io::{BufReader, Cursor};
use std::path::Path;

use tiff::decoder::{Decoder, DecodingResult};
use tiff::tags::Tag;

use super::GeoImageError;

/// TIFF PhotometricInterpretation values.
const WHITE_IS_ZERO: u16 = 0;
const BLACK_IS_ZERO: u16 = 1;
const RGB: u16 = 2;
const PALETTE: u16 = 3;

/// TIFF PlanarConfiguration value for one plane per sample.
const PLANAR: u16 = 2;

/// TIFF ExtraSamples values that mean alpha.
const ASSOCIATED_ALPHA: u16 = 1;
const UNASSOCIATED_ALPHA: u16 = 2;

/// A decoded image: `width × height` RGBA8 pixels, row-major.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Rgba8 {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<u8>,
}

/// The sample layout of a TIFF image, read from its tags.
#[derive(Debug, Clone)]
struct TiffLayout {
    width: u32,
    height: u32,
    photometric: u16,
    samples_per_pixel: usize,
    bits: u16,
    planar: bool,
    alpha: bool,
    color_map: Vec<u16>,
}

fn tiff_err(path: &Path) -> impl Fn(tiff::TiffError) -> GeoImageError + '_ {
    move |source| GeoImageError::Tiff {
        path: path.to_path_buf(),
        source,
    }
}

fn unsupported(path: &Path, message: String) -> GeoImageError {
    GeoImageError::UnsupportedPixels {
        path: path.to_path_buf(),
        message,
    }
}

/// Decodes the first image of the TIFF file `bytes` (read from `path`) to RGBA8.
pub(crate) fn tiff_to_rgba8(path: &Path, mut bytes: Vec<u8>) -> Result<Rgba8, GeoImageError> {
    let (layout, ifd_offset) = {
        let mut decoder = Decoder::new(Cursor::new(&bytes)).map_err(tiff_err(path))?;
        let layout = read_layout(path, &mut decoder)?;
        (layout, decoder.ifd_pointer().map(|p| p.0))
    };
    if layout.photometric == PALETTE {
        let offset = ifd_offset.ok_or_else(|| unsupported(path, "no image directory".into()))?;
        rewrite_photometric(&mut bytes, offset, BLACK_IS_ZERO).map_err(|message| {
            GeoImageError::Malformed {
                path: path.to_path_buf(),
                message,
            }
        })?;
    }
    let mut decoder = Decoder::new(Cursor::new(&bytes)).map_err(tiff_err(path))?;
    let mut result = DecodingResult::U8(Vec::new());
    let buffer_layout = decoder
        .read_image_to_buffer(&mut result)
        .map_err(tiff_err(path))?;
    let samples = raw_samples(path, &layout, &result, buffer_layout.complete_len)?;
    let pixels = to_rgba(path, &layout, &samples)?;
    Ok(Rgba8 {
        width: layout.width,
        height: layout.height,
        pixels,
    })
}

fn read_layout<R: std::io::Read + std::io::Seek>(
    path: &Path,
    decoder: &mut Decoder<R>,
) -> Result<TiffLayout, GeoImageError> {
    let err = tiff_err(path);
    let (width, height) = decoder.dimensions().map_err(&err)?;
    let u16_tag = |d: &mut Decoder<R>, tag| d.find_tag_unsigned::<u16>(tag).map_err(&err);
    let u16_vec = |d: &mut Decoder<R>, tag| d.find_tag_unsigned_vec::<u16>(tag).map_err(&err);
    let photometric = u16_tag(decoder, Tag::PhotometricInterpretation)?.unwrap_or(BLACK_IS_ZERO);
    let samples_per_pixel = usize::from(u16_tag(decoder, Tag::SamplesPerPixel)?.unwrap_or(1));
    let bits_all = u16_vec(decoder, Tag::BitsPerSample)?.unwrap_or_else(|| vec![1]);
    let planar = u16_tag(decoder, Tag::PlanarConfiguration)?.unwrap_or(1) == PLANAR;
    let extra = u16_vec(decoder, Tag::ExtraSamples)?.unwrap_or_default();
    let formats = u16_vec(decoder, Tag::SampleFormat)?.unwrap_or_else(|| vec![1]);
    let color_map = if photometric == PALETTE {
        u16_vec(decoder, Tag::ColorMap)?.unwrap_or_default()
    } else {
        Vec::new()
    };
    let bits = bits_all.first().copied().unwrap_or(1);
    if bits_all.iter().any(|b| *b != bits) {
        return Err(unsupported(
            path,
            format!("mixed bits per sample {bits_all:?}"),
        ));
    }
    if !matches!(bits, 1 | 2 | 4 | 8 | 16) {
        return Err(unsupported(path, format!("{bits} bits per sample")));
    }
    if formats.iter().any(|f| *f != 1) {
        return Err(unsupported(
            path,
            format!("sample format {formats:?} (only unsigned)"),
        ));
    }
    if photometric == PALETTE && color_map.len() != 3 << bits {
        return Err(unsupported(
            path,
            format!(
                "palette with {} ColorMap entries, {} expected",
                color_map.len(),
                3 << bits
            ),
        ));
    }
    let colour_samples = if photometric == RGB { 3 } else { 1 };
    let alpha = samples_per_pixel > colour_samples
        && matches!(
            extra.first(),
            Some(&(ASSOCIATED_ALPHA | UNASSOCIATED_ALPHA))
        );
    Ok(TiffLayout {
        width,
        height,
        photometric,
        samples_per_pixel,
        bits,
        planar,
        alpha,
        color_map,
    })
}

/// The decoded samples as `[pixel][sample]` rows of `per_pixel` u16 values.
struct Samples {
    values: Vec<u16>,
    per_pixel: usize,
}

impl Samples {
    fn get(&self, pixel: usize, sample: usize) -> u16 {
        self.values[pixel * self.per_pixel + sample]
    }
}

fn raw_samples(
    path: &Path,
    layout: &TiffLayout,
    result: &DecodingResult,
    complete_len: usize,
) -> Result<Samples, GeoImageError> {
    let pixels = layout.width as usize * layout.height as usize;
    let values: Vec<u16> = match result {
        DecodingResult::U8(v) if layout.bits == 8 => v.iter().map(|b| u16::from(*b)).collect(),
        DecodingResult::U8(v) => unpack_bits(v, layout),
        DecodingResult::U16(v) => v.clone(),
        _ => return Err(unsupported(path, "unexpected sample type".into())),
    };
    let byte_len = match result {
        DecodingResult::U16(v) => v.len() * 2,
        DecodingResult::U8(v) => v.len(),
        _ => 0,
    };
    if byte_len < complete_len || pixels == 0 || values.len() < pixels {
        return Err(unsupported(
            path,
            "image too large to decode all planes".into(),
        ));
    }
    // The decoder may keep or drop extra samples; infer how many it kept per pixel.
    let per_pixel = values.len() / pixels;
    let values = if layout.planar {
        // Plane-major → pixel-major.
        let mut chunky = vec![0u16; pixels * per_pixel];
        for (plane, band) in values.chunks_exact(pixels).enumerate().take(per_pixel) {
            for (pixel, v) in band.iter().enumerate() {
                chunky[pixel * per_pixel + plane] = *v;
            }
        }
        chunky
    } else {
        values
    };
    Ok(Samples { values, per_pixel })
}

/// Unpacks 1-, 2- or 4-bit samples; each row starts on a byte boundary.
fn unpack_bits(packed: &[u8], layout: &TiffLayout) -> Vec<u16> {
    let bits = usize::from(layout.bits);
    let row_samples = layout.width as usize * layout.samples_per_pixel;
    let row_bytes = (row_samples * bits).div_ceil(8);
    let mask = (1u16 << bits) - 1;
    let mut out = Vec::with_capacity(row_samples * layout.height as usize);
    for row in packed.chunks(row_bytes).take(layout.height as usize) {
        for i in 0..row_samples {
            let bit = i * bits;
            let byte = row.get(bit / 8).copied().unwrap_or(0);
            let shift = 8 - bits - bit % 8;
            out.push((u16::from(byte) >> shift) & mask);
        }
    }
    out
}

fn to_rgba(path: &Path, layout: &TiffLayout, samples: &Samples) -> Result<Vec<u8>, GeoImageError> {
    let pixels = layout.width as usize * layout.height as usize;
    let max = (1u32 << layout.bits) - 1;
    let scale = |v: u16| ((u32::from(v) * 255 + max / 2) / max) as u8;
    let mut out = Vec::with_capacity(pixels * 4);
    match layout.photometric {
        WHITE_IS_ZERO | BLACK_IS_ZERO => {
            for p in 0..pixels {
                let g = scale(samples.get(p, 0));
                let a = if layout.alpha && samples.per_pixel > 1 {
                    scale(samples.get(p, 1))
                } else {
                    255
                };
                out.extend_from_slice(&[g, g, g, a]);
            }
        }
        RGB if samples.per_pixel >= 3 => {
            for p in 0..pixels {
                let a = if layout.alpha && samples.per_pixel > 3 {
                    scale(samples.get(p, 3))
                } else {
                    255
                };
                out.extend_from_slice(&[
                    scale(samples.get(p, 0)),
                    scale(samples.get(p, 1)),
                    scale(samples.get(p, 2)),
                    a,
                ]);
            }
        }
        PALETTE => {
            let n = 1usize << layout.bits;
            let map = &layout.color_map;
            let entry = |i: usize| ((u32::from(map[i]) * 255 + 32767) / 65535) as u8;
            for p in 0..pixels {
                let i = usize::from(samples.get(p, 0));
                out.extend_from_slice(&[entry(i), entry(n + i), entry(2 * n + i), 255]);
            }
        }
        other => {
            return Err(unsupported(
                path,
                format!(
                    "photometric interpretation {other} with {} samples",
                    samples.per_pixel
                ),
            ));
        }
    }
    Ok(out)
}

/// Rewrites the PhotometricInterpretation entry of the IFD at `ifd_offset` in a classic or
/// BigTIFF file held in memory.
fn rewrite_photometric(bytes: &mut [u8], ifd_offset: u64, value: u16) -> Result<(), String> {
    let too_short = || "TIFF directory runs past the end of the file".to_string();
    let little = match bytes.get(0..2) {
        Some(b"II") => true,
        Some(b"MM") => false,
        _ => return Err("not a TIFF byte-order mark".into()),
    };
    let read_u16 = |b: &[u8], at: usize| -> Option<u16> {
        let v: [u8; 2] = b.get(at..at + 2)?.try_into().ok()?;
        Some(if little {
            u16::from_le_bytes(v)
        } else {
            u16::from_be_bytes(v)
        })
    };
    let big_tiff = read_u16(bytes, 2) == Some(43);
    let offset = usize::try_from(ifd_offset).map_err(|_| too_short())?;
    let (count, first, entry_len) = if big_tiff {
        let v: [u8; 8] = bytes
            .get(offset..offset + 8)
            .ok_or_else(too_short)?
            .try_into()
            .map_err(|_| too_short())?;
        let n = if little {
            u64::from_le_bytes(v)
        } else {
            u64::from_be_bytes(v)
        };
        (usize::try_from(n).map_err(|_| too_short())?, offset + 8, 20)
    } else {
        (
            usize::from(read_u16(bytes, offset).ok_or_else(too_short)?),
            offset + 2,
            12,
        )
    };
    for i in 0..count {
        let entry = first + i * entry_len;
        let tag = read_u16(bytes, entry).ok_or_else(too_short)?;
        if tag == Tag::PhotometricInterpretation.to_u16() {
            // Type SHORT, count 1: the value is inline at the start of the value field.
            let at = entry + if big_tiff { 12 } else { 8 };
            let field = bytes.get_mut(at..at + 2).ok_or_else(too_short)?;
            field.copy_from_slice(&if little {
                value.to_le_bytes()
            } else {
                value.to_be_bytes()
            });
            return Ok(());
        }
    }
    Err("palette image without a PhotometricInterpretation entry".into())
}

/// Decodes a PNG file to RGBA8 (grey, grey+alpha, RGB, RGBA, palette; 16-bit reduced to 8).
pub(crate) fn png_to_rgba8(path: &Path) -> Result<Rgba8, GeoImageError> {
    let file = std::fs::File::open(path).map_err(|source| GeoImageError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let png_err = |source| GeoImageError::Png {
        path: path.to_path_buf(),
        source,
    };
    let mut decoder = png::Decoder::new(BufReader::new(file));
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder.read_info().map_err(png_err)?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| unsupported(path, "image too large".into()))?;
    let mut buf = vec![0u8; size];
    let info = reader.next_frame(&mut buf).map_err(png_err)?;
    buf.truncate(info.buffer_size());
    let pixels = match info.color_type {
        png::ColorType::Rgba => buf,
        png::ColorType::Rgb => buf
            .chunks_exact(3)
            .flat_map(|p| [p[0], p[1], p[2], 255])
            .collect(),
        png::ColorType::Grayscale => buf.iter().flat_map(|g| [*g, *g, *g, 255]).collect(),
        png::ColorType::GrayscaleAlpha => buf
            .chunks_exact(2)
            .flat_map(|p| [p[0], p[0], p[0], p[1]])
            .collect(),
        png::ColorType::Indexed => {
            return Err(unsupported(path, "palette PNG was not expanded".into()));
        }
    };
    Ok(Rgba8 {
        width: info.width,
        height: info.height,
        pixels,
    })
}

/// Decodes a JPEG file to RGBA8.
pub(crate) fn jpeg_to_rgba8(path: &Path) -> Result<Rgba8, GeoImageError> {
    use zune_jpeg::zune_core::{
        bytestream::ZCursor, colorspace::ColorSpace, options::DecoderOptions,
    };
    let bytes = std::fs::read(path).map_err(|source| GeoImageError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let jpeg_err = |e: zune_jpeg::errors::DecodeErrors| GeoImageError::Jpeg {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let options = DecoderOptions::default().jpeg_set_out_colorspace(ColorSpace::RGBA);
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(ZCursor::new(&bytes), options);
    let pixels = decoder.decode().map_err(jpeg_err)?;
    let info = decoder
        .info()
        .ok_or_else(|| unsupported(path, "JPEG headers not decoded".into()))?;
    Ok(Rgba8 {
        width: u32::from(info.width),
        height: u32::from(info.height),
        pixels,
    })
}

/// Width and height of a JPEG without decoding its pixels.
pub(crate) fn jpeg_dimensions(path: &Path) -> Result<(u32, u32), GeoImageError> {
    use zune_jpeg::zune_core::bytestream::ZCursor;
    let bytes = std::fs::read(path).map_err(|source| GeoImageError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let mut decoder = zune_jpeg::JpegDecoder::new(ZCursor::new(&bytes));
    decoder.decode_headers().map_err(|e| GeoImageError::Jpeg {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let info = decoder
        .info()
        .ok_or_else(|| unsupported(path, "JPEG headers not decoded".into()))?;
    Ok((u32::from(info.width), u32::from(info.height)))
}

/// Width and height of a PNG without decoding its pixels.
pub(crate) fn png_dimensions(path: &Path) -> Result<(u32, u32), GeoImageError> {
    let file = std::fs::File::open(path).map_err(|source| GeoImageError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let reader = png::Decoder::new(BufReader::new(file))
        .read_info()
        .map_err(|source| GeoImageError::Png {
            path: path.to_path_buf(),
            source,
        })?;
    let info = reader.info();
    Ok((info.width, info.height))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unpacks_four_bit_rows_on_byte_boundaries() {
        let layout = TiffLayout {
            width: 3,
            height: 2,
            photometric: PALETTE,
            samples_per_pixel: 1,
            bits: 4,
            planar: false,
            alpha: false,
            color_map: Vec::new(),
        };
        // Row 0: 1, 2, 3 (+ pad nibble); row 1: 15, 0, 7 (+ pad).
        let v = unpack_bits(&[0x12, 0x30, 0xF0, 0x70], &layout);
        assert_eq!(v, vec![1, 2, 3, 15, 0, 7]);
    }

    #[test]
    fn rewrites_photometric_in_a_big_endian_directory() {
        // MM header, IFD at 8 with 2 entries: ImageWidth, PhotometricInterpretation = 3.
        let mut tiff = vec![b'M', b'M', 0, 42, 0, 0, 0, 8, 0, 2];
        tiff.extend_from_slice(&[1, 0, 0, 3, 0, 0, 0, 1, 0, 5, 0, 0]);
        tiff.extend_from_slice(&[1, 6, 0, 3, 0, 0, 0, 1, 0, 3, 0, 0]);
        rewrite_photometric(&mut tiff, 8, BLACK_IS_ZERO).unwrap();
        assert_eq!(&tiff[30..32], &[0, 1]);
        assert!(rewrite_photometric(&mut tiff[..20].to_vec(), 8, 1).is_err());
    }
}
