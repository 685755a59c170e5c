//! Lossless codecs for recorded frames, measured on rendered fringe frames: bytes per frame and
//! encode / decode CPU time, for full frames and for the square around the disc.
//!
//! `cargo run --release -p fringe-sim --example frame_codec_bench [-- FRAMES [NAME...]]`
//! (default 12 frames per sensor build: no contact, then the pentagon and the rectangle pressed
//! from 1 to 9 N at places across the disc, on the layered and the integrated sensor).
//!
//! Candidates, each checked to give back every byte it was given:
//! - `png rgb8`: the RGB8 frame in an RGB PNG, fast deflate, Sub filter (what runs stored
//!   before the native format was recorded);
//! - `png mosaic`: the BayerRG8 mosaic as a grey PNG, same settings (the Sub filter then predicts
//!   a pixel from its neighbour of another colour);
//! - `png planes <filter>`: the mosaic rearranged into its four colour planes (R, G on red rows,
//!   G on blue rows, B; each a quarter of the image, side by side in one grey image), so every
//!   filter predicts from same-colour neighbours; fast deflate;
//! - `qoi cells`: QOI of the 2x2 Bayer cells as RGBA pixels (R, G, G, B);
//! - `webp cells`: lossless WebP (image-webp's encoder) of the same RGBA cells;
//! - `tiff planes`: TIFF with deflate and the horizontal predictor on the planes;
//! - `zstd planes N`: the planes after a left-neighbour difference, zstd level N;
//! - `fgl mosaic`: fringe's own codec (`fringe_rig::store::encode_fgl`, what runs store since
//!   layout 3) on the mosaic as it is;
//! - for a Mono8 camera, `png mono8 avg` and `fgl mono8`: the same scenes rendered grey, in a
//!   grey PNG as runs of layout 2 stored them, and in FGL.
//!
//! `-- FRAMES NAME...` measures only the candidates named (for example `"fgl mosaic"`).
//!
//! Times are per frame on one thread (wall clock of the encode or decode call, the fastest of
//! three calls on each frame, median over the frames; the machine otherwise idle).

use fringe_rig::store;
use fringe_rig::store::FglPattern as Pattern;
use fringe_rig::PixelFormat;
use fringe_rig::{Millimetres, Newtons};
use fringe_sim::Renderer;
use fringe_sim::SensorConfig;
use fringe_sim::{Contact, FrameRenderer, Scene};
use std::io::Cursor;
use std::time::Instant;

type Encode = fn(&[u8], u32, u32) -> Vec<u8>;
type Decode = fn(&[u8], u32, u32) -> Vec<u8>;

/// One grey or RGB image to compress.
struct Image {
    data: Vec<u8>,
    width: u32,
    height: u32,
}

fn png(data: &[u8], w: u32, h: u32, colour: png::ColorType, filter: png::Filter) -> Vec<u8> {
    png_level(
        data,
        w,
        h,
        colour,
        filter,
        png::DeflateCompression::FdeflateUltraFast,
    )
}

fn png_level(
    data: &[u8],
    w: u32,
    h: u32,
    colour: png::ColorType,
    filter: png::Filter,
    deflate: png::DeflateCompression,
) -> Vec<u8> {
    let mut out = Vec::new();
    let mut enc = png::Encoder::new(&mut out, w, h);
    enc.set_color(colour);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_deflate_compression(deflate);
    enc.set_filter(filter);
    let mut writer = enc.write_header().expect("png header");
    writer.write_image_data(data).expect("png data");
    writer.finish().expect("png end");
    out
}

fn unpng(bytes: &[u8], _: u32, _: u32) -> Vec<u8> {
    let mut reader = png::Decoder::new(Cursor::new(bytes))
        .read_info()
        .expect("png info");
    let mut buf = vec![0; reader.output_buffer_size().expect("png size")];
    let info = reader.next_frame(&mut buf).expect("png frame");
    buf.truncate(info.buffer_size());
    buf
}

/// The mosaic's four colour planes side by side: [R | G(red rows)] over [G(blue rows) | B].
fn planes(mosaic: &[u8], w: u32, h: u32) -> Vec<u8> {
    let (w, h) = (w as usize, h as usize);
    let (hw, hh) = (w / 2, h / 2);
    let mut out = vec![0; w * h];
    for (row, line) in mosaic.chunks_exact(w).enumerate() {
        let dst_row = (row & 1) * hh + row / 2;
        let dst = &mut out[dst_row * w..(dst_row + 1) * w];
        for (col, &v) in line.iter().enumerate() {
            dst[(col & 1) * hw + col / 2] = v;
        }
    }
    out
}

fn unplanes(planar: &[u8], w: u32, h: u32) -> Vec<u8> {
    let (w, h) = (w as usize, h as usize);
    let (hw, hh) = (w / 2, h / 2);
    let mut out = vec![0; w * h];
    for (row, line) in out.chunks_exact_mut(w).enumerate() {
        let src_row = (row & 1) * hh + row / 2;
        let src = &planar[src_row * w..(src_row + 1) * w];
        for (col, v) in line.iter_mut().enumerate() {
            *v = src[(col & 1) * hw + col / 2];
        }
    }
    out
}

/// 2x2 Bayer cells as RGBA pixels (R, G, G, B).
fn cells(mosaic: &[u8], w: u32, h: u32) -> Vec<u8> {
    let (w, h) = (w as usize, h as usize);
    let mut out = Vec::with_capacity(w * h);
    for r in (0..h).step_by(2) {
        for c in (0..w).step_by(2) {
            out.extend_from_slice(&[
                mosaic[r * w + c],
                mosaic[r * w + c + 1],
                mosaic[(r + 1) * w + c],
                mosaic[(r + 1) * w + c + 1],
            ]);
        }
    }
    out
}

fn uncells(rgba: &[u8], w: u32, h: u32) -> Vec<u8> {
    let (w, h) = (w as usize, h as usize);
    let mut out = vec![0; w * h];
    for (k, p) in rgba.chunks_exact(4).enumerate() {
        let (r, c) = (2 * (k / (w / 2)), 2 * (k % (w / 2)));
        out[r * w + c] = p[0];
        out[r * w + c + 1] = p[1];
        out[(r + 1) * w + c] = p[2];
        out[(r + 1) * w + c + 1] = p[3];
    }
    out
}

fn left_delta(data: &[u8], w: u32) -> Vec<u8> {
    let mut out = Vec::with_capacity(data.len());
    for line in data.chunks_exact(w as usize) {
        let mut prev = 0u8;
        for &v in line {
            out.push(v.wrapping_sub(prev));
            prev = v;
        }
    }
    out
}

fn undo_left_delta(data: &[u8], w: u32) -> Vec<u8> {
    let mut out = Vec::with_capacity(data.len());
    for line in data.chunks_exact(w as usize) {
        let mut prev = 0u8;
        for &d in line {
            prev = prev.wrapping_add(d);
            out.push(prev);
        }
    }
    out
}

fn tiff_planes(mosaic: &[u8], w: u32, h: u32) -> Vec<u8> {
    use tiff::encoder::{colortype::Gray8, Compression, DeflateLevel, Predictor, TiffEncoder};
    let mut out = Cursor::new(Vec::new());
    TiffEncoder::new(&mut out)
        .expect("tiff")
        .with_compression(Compression::Deflate(DeflateLevel::Fast))
        .with_predictor(Predictor::Horizontal)
        .write_image::<Gray8>(w, h, &planes(mosaic, w, h))
        .expect("tiff image");
    out.into_inner()
}

fn untiff_planes(bytes: &[u8], w: u32, h: u32) -> Vec<u8> {
    let mut d = tiff::decoder::Decoder::new(Cursor::new(bytes)).expect("tiff decoder");
    match d.read_image().expect("tiff read") {
        tiff::decoder::DecodingResult::U8(v) => unplanes(&v, w, h),
        _ => panic!("tiff: not 8-bit"),
    }
}

fn webp_cells(mosaic: &[u8], w: u32, h: u32) -> Vec<u8> {
    let mut out = Vec::new();
    image_webp::WebPEncoder::new(&mut out)
        .encode(
            &cells(mosaic, w, h),
            w / 2,
            h / 2,
            image_webp::ColorType::Rgba8,
        )
        .expect("webp");
    out
}

fn unwebp_cells(bytes: &[u8], w: u32, h: u32) -> Vec<u8> {
    let mut d = image_webp::WebPDecoder::new(Cursor::new(bytes)).expect("webp decoder");
    let mut buf = vec![0; d.output_buffer_size().expect("webp size")];
    d.read_image(&mut buf).expect("webp read");
    uncells(&buf, w, h)
}

fn zstd_planes(mosaic: &[u8], w: u32, h: u32, level: i32) -> Vec<u8> {
    zstd::bulk::compress(&left_delta(&planes(mosaic, w, h), w), level).expect("zstd")
}

fn unzstd_planes(bytes: &[u8], w: u32, h: u32) -> Vec<u8> {
    let delta = zstd::bulk::decompress(bytes, (w * h) as usize).expect("unzstd");
    unplanes(&undo_left_delta(&delta, w), w, h)
}

fn jxl(data: &[u8], w: u32, h: u32, space: zune_core::colorspace::ColorSpace) -> Vec<u8> {
    use zune_core::{bit_depth::BitDepth, options::EncoderOptions};
    let mut out = Vec::new();
    zune_jpegxl::JxlSimpleEncoder::new(
        data,
        EncoderOptions::new(w as usize, h as usize, space, BitDepth::Eight),
    )
    .encode(&mut out)
    .expect("jxl");
    out
}

fn unjxl(bytes: &[u8]) -> Vec<u8> {
    let image = jxl_oxide::JxlImage::builder()
        .read(Cursor::new(bytes))
        .expect("jxl read");
    let render = image.render_frame(0).expect("jxl render");
    let fb = render.image_all_channels();
    fb.buf()
        .iter()
        .map(|v| (v * 255.0).round().clamp(0.0, 255.0) as u8)
        .collect()
}

fn fgl(data: &[u8], w: u32, h: u32, pattern: Pattern) -> Vec<u8> {
    store::encode_fgl(data, w, h, pattern).expect("fgl")
}

fn unfgl(bytes: &[u8], _: u32, _: u32) -> Vec<u8> {
    store::decode_fgl(bytes).expect("unfgl").pixels
}

/// The candidates for the mosaic, by name.
fn mosaic_codecs() -> Vec<(&'static str, Encode, Decode)> {
    use png::{ColorType::Grayscale, Filter};
    vec![
        (
            "png mosaic sub",
            |m, w, h| png(m, w, h, Grayscale, Filter::Sub),
            unpng,
        ),
        (
            "png planes sub",
            |m, w, h| png(&planes(m, w, h), w, h, Grayscale, Filter::Sub),
            |b, w, h| unplanes(&unpng(b, w, h), w, h),
        ),
        (
            "png planes up",
            |m, w, h| png(&planes(m, w, h), w, h, Grayscale, Filter::Up),
            |b, w, h| unplanes(&unpng(b, w, h), w, h),
        ),
        (
            "png planes avg",
            |m, w, h| png(&planes(m, w, h), w, h, Grayscale, Filter::Avg),
            |b, w, h| unplanes(&unpng(b, w, h), w, h),
        ),
        (
            "png planes avg zlib1",
            |m, w, h| {
                png_level(
                    &planes(m, w, h),
                    w,
                    h,
                    Grayscale,
                    Filter::Avg,
                    png::DeflateCompression::Level(1),
                )
            },
            |b, w, h| unplanes(&unpng(b, w, h), w, h),
        ),
        (
            "png planes avg zlib6",
            |m, w, h| {
                png_level(
                    &planes(m, w, h),
                    w,
                    h,
                    Grayscale,
                    Filter::Avg,
                    png::DeflateCompression::Level(6),
                )
            },
            |b, w, h| unplanes(&unpng(b, w, h), w, h),
        ),
        (
            "png planes paeth",
            |m, w, h| png(&planes(m, w, h), w, h, Grayscale, Filter::Paeth),
            |b, w, h| unplanes(&unpng(b, w, h), w, h),
        ),
        (
            "png planes adaptive",
            |m, w, h| png(&planes(m, w, h), w, h, Grayscale, Filter::Adaptive),
            |b, w, h| unplanes(&unpng(b, w, h), w, h),
        ),
        (
            "qoi cells",
            |m, w, h| qoi::encode_to_vec(cells(m, w, h), w / 2, h / 2).expect("qoi"),
            |b, w, h| uncells(&qoi::decode_to_vec(b).expect("unqoi").1, w, h),
        ),
        ("webp cells", webp_cells, unwebp_cells),
        (
            "jxl planes",
            |m, w, h| {
                jxl(
                    &planes(m, w, h),
                    w,
                    h,
                    zune_core::colorspace::ColorSpace::Luma,
                )
            },
            |b, w, h| unplanes(&unjxl(b), w, h),
        ),
        (
            "jxl cells",
            |m, w, h| {
                jxl(
                    &cells(m, w, h),
                    w / 2,
                    h / 2,
                    zune_core::colorspace::ColorSpace::RGBA,
                )
            },
            |b, w, h| uncells(&unjxl(b), w, h),
        ),
        ("tiff planes", tiff_planes, untiff_planes),
        (
            "fgl mosaic",
            |m, w, h| fgl(m, w, h, Pattern::Mosaic2x2),
            unfgl,
        ),
        (
            "zstd planes 1",
            |m, w, h| zstd_planes(m, w, h, 1),
            unzstd_planes,
        ),
        (
            "zstd planes 3",
            |m, w, h| zstd_planes(m, w, h, 3),
            unzstd_planes,
        ),
    ]
}

/// The square around the disc, on even coordinates (the Bayer pattern stays RG), 16 px margin.
fn disc_square(config: &SensorConfig) -> (u32, u32, u32) {
    let g = &config.geometry;
    let half = (g.disc_radius_px + 16.0).ceil() as u32 & !1;
    let cx = (g.width as f64 / 2.0 + g.centre_offset_px[0]).round() as u32 & !1;
    let cy = (g.height as f64 / 2.0 + g.centre_offset_px[1]).round() as u32 & !1;
    let x0 = cx.saturating_sub(half);
    let y0 = cy.saturating_sub(half);
    let side = (2 * half).min(g.width - x0).min(g.height - y0) & !1;
    (x0, y0, side)
}

fn crop(img: &Image, bpp: usize, (x0, y0, side): (u32, u32, u32)) -> Image {
    let mut data = Vec::with_capacity((side * side) as usize * bpp);
    for r in y0..y0 + side {
        let start = (r * img.width + x0) as usize * bpp;
        data.extend_from_slice(&img.data[start..start + side as usize * bpp]);
    }
    Image {
        data,
        width: side,
        height: side,
    }
}

/// The entropy of the renderer's noise, MB per frame: no lossless codec can store a frame in
/// fewer bytes on average. Each pixel's noise is Gaussian with variance a I + b (the sensor file's
/// `noise.poisson_a`, `noise.gaussian_b`), whose quantised entropy is close to
/// log2(2 pi e var) / 2 bits once the standard deviation is above about 0.6 DN.
fn noise_floor_mb(images: &[Image], a: f64, b: f64) -> f64 {
    let bits: f64 = images
        .iter()
        .flat_map(|img| img.data.iter())
        .map(|&v| {
            0.5 * (2.0 * std::f64::consts::PI * std::f64::consts::E * (a * f64::from(v) + b)).log2()
        })
        .sum();
    bits / 8.0 / 1e6 / images.len() as f64
}

/// Median of `times`, ms.
fn median(mut times: Vec<f64>) -> f64 {
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

fn measure(only: &[String], name: &str, images: &[Image], enc: Encode, dec: Decode) {
    if !only.is_empty() && !only.iter().any(|o| o == name) {
        return;
    }
    let (mut bytes, mut te, mut td) = (0usize, Vec::new(), Vec::new());
    for img in images {
        // The fastest of three calls: this machine's other load only ever adds time.
        let (mut packed, mut back) = (Vec::new(), Vec::new());
        let (mut best_e, mut best_d) = (f64::MAX, f64::MAX);
        for _ in 0..3 {
            let t = Instant::now();
            packed = enc(&img.data, img.width, img.height);
            best_e = best_e.min(t.elapsed().as_secs_f64() * 1e3);
            let t = Instant::now();
            back = dec(&packed, img.width, img.height);
            best_d = best_d.min(t.elapsed().as_secs_f64() * 1e3);
        }
        te.push(best_e);
        td.push(best_d);
        assert!(back == img.data, "{name}: not lossless");
        bytes += packed.len();
    }
    println!(
        "| {name:<20} | {:7.3} | {:6.1} | {:6.1} |",
        bytes as f64 / images.len() as f64 / 1e6,
        median(te),
        median(td)
    );
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let per_sensor: usize = match std::env::args().nth(1) {
        Some(a) => a.parse()?,
        None => 12,
    };
    let only: Vec<String> = std::env::args().skip(2).collect();
    let (mut rgb, mut mosaic, mut rgb_crop, mut mosaic_crop) = (vec![], vec![], vec![], vec![]);
    let (mut mono, mut mono_crop) = (vec![], vec![]);
    let configs = [SensorConfig::layered(), SensorConfig::integrated()];
    let noise = &configs[0].noise;
    let (a, b) = (noise.poisson_a, noise.gaussian_b);
    assert!(
        configs.iter().all(|c| c.noise == *noise),
        "the floor below assumes both builds have the same noise"
    );
    for config in configs {
        let square = disc_square(&config);
        let mut renderer = Renderer::new(config)?;
        let (w, h) = (renderer.width(), renderer.height());
        let shapes = [renderer.config().pentagon(), renderer.config().rectangle()];
        for k in 0..per_sensor {
            let s = k as f64 / per_sensor.max(2) as f64;
            let a = std::f64::consts::TAU * s;
            let contact = (k > 0).then_some(Contact {
                shape: shapes[k % 2],
                force: Newtons(1.0 + 8.0 * s),
                x: Millimetres(12.0 * a.cos()),
                y: Millimetres(8.0 * a.sin()),
                angle_deg: 60.0 * s,
                shear: None,
            });
            let scene = Scene { contact };
            for (format, all, cropped, bpp) in [
                (PixelFormat::Rgb8, &mut rgb, &mut rgb_crop, 3),
                (PixelFormat::BayerRg8, &mut mosaic, &mut mosaic_crop, 1),
                (PixelFormat::Mono8, &mut mono, &mut mono_crop, 1),
            ] {
                let mut data = Vec::new();
                renderer.render_as(&scene, k as u64, format, &mut data);
                let img = Image {
                    data,
                    width: w,
                    height: h,
                };
                cropped.push(crop(&img, bpp, square));
                all.push(img);
            }
        }
    }
    let (side_w, side_h) = (mosaic_crop[0].width, mosaic_crop[0].height);
    for (title, rgb, mosaic, mono) in [
        ("full frames 1920x1200", &rgb, &mosaic, &mono),
        (
            &*format!("disc square {side_w}x{side_h}"),
            &rgb_crop,
            &mosaic_crop,
            &mono_crop,
        ),
    ] {
        println!(
            "\n{title}, {} frames; the BayerRG8 noise's entropy: {:.3} MB/frame\n\n\
             | codec                | MB/frame | encode ms | decode ms |\n|---|---|---|---|",
            mosaic.len(),
            noise_floor_mb(mosaic, a, b)
        );
        measure(
            &only,
            "png rgb8 sub",
            rgb,
            |d, w, h| png(d, w, h, png::ColorType::Rgb, png::Filter::Sub),
            unpng,
        );
        for (name, enc, dec) in mosaic_codecs() {
            measure(&only, name, mosaic, enc, dec);
        }
        measure(
            &only,
            "png mono8 avg",
            mono,
            |d, w, h| png(d, w, h, png::ColorType::Grayscale, png::Filter::Avg),
            unpng,
        );
        measure(
            &only,
            "fgl mono8",
            mono,
            |d, w, h| fgl(d, w, h, Pattern::Mono),
            unfgl,
        );
    }
    Ok(())
}
