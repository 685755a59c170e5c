//! FGL, the lossless codec of one-channel frames (Mono8, or a BayerRG8 mosaic as it is): bytes
//! in, bytes out, no I/O.
//!
//! Why a codec of our own: the frames are dominated by the camera's noise, and what a lossless
//! codec can save is in predicting each pixel with as little of that noise as possible and in
//! coding the residual by the local activity. PNG predicts from one or two neighbours and codes
//! with deflate; the maintained alternatives measured beside it (QOI, lossless WebP, JPEG XL,
//! TIFF, zstd; BENCHMARKS.md, "Recording: bytes and CPU per frame") are no smaller at the same
//! CPU. FGL predicts each pixel as the mean of four neighbours of its own colour and codes the
//! residual with one of up to [`MAX_CONTEXTS`] Huffman tables, chosen by the activity around
//! the pixel: about 11 % fewer bytes than the planes PNG, at about a quarter less CPU to encode
//! and half again as much to decode (BENCHMARKS.md, "A faster encoder, and FGL the default").
//!
//! The file (all integers little-endian):
//!
//! | bytes | content |
//! |---|---|
//! | 4 | `FGL2` (version 2; `FGL1` in files of version 1) |
//! | 4, 4 | width, height (px) |
//! | 1 | pattern: 0 one colour ([`Pattern::Mono`]), 1 a 2x2 colour mosaic ([`Pattern::Mosaic2x2`]) |
//! | 1 | K, the number of contexts (1 to [`MAX_CONTEXTS`]) |
//! | 2 (K - 1) | the activity thresholds, ascending: a pixel's context is how many it reaches |
//! | 128 K | per context, the code length of each of the 256 residual symbols, 4 bits each (low nibble first; 0: the symbol does not occur) |
//! | rest | the residuals' codes, rows top to bottom, least significant bit first |
//! | 4 | version 2 only: the CRC-32 (IEEE, as PNG and zlib) of every byte before it |
//!
//! Version 2 (written since runs of layout 4) adds the checksum: a bit changed on the disk is
//! found when the file is read, instead of decoding to other pixels. Files of version 1 (runs of
//! layout 3) have none and are still read; a later version is refused, naming it.
//!
//! Prediction, with `s` the distance to the nearest pixel of the same colour (1 for one colour,
//! 2 in a mosaic) and W, N, NW, NE the same-colour neighbours left, above, above-left and
//! above-right: `(W + N + NW + NE + 2) / 4` (a neighbour past the left or right edge is
//! replaced by N); in the first `s` rows, W; the first pixel of each colour, 128. The activity is
//! `|N - NW| + |NE - N| + |W - NW|`; in the first `s` rows, the last context. The residual is
//! the pixel minus its prediction modulo 256, folded to a symbol as 0, -1, 1, -2, 2, ... The
//! codes are canonical Huffman codes of at most [`MAX_CODE_BITS`] bits.

/// Most contexts a file may have.
pub(crate) const MAX_CONTEXTS: usize = 8;
/// Longest code, bits.
pub(crate) const MAX_CODE_BITS: u32 = 12;
/// Largest image accepted, px (a header is refused before anything of that size is allocated).
pub(crate) const MAX_PIXELS: u64 = 1 << 28;

/// Bytes of the header that [`header`] reads: magic, width, height, pattern.
pub(crate) const HEADER_BYTES: usize = 13;

/// The first bytes of a file of each version: `FGL` and the version's digit.
const MAGIC_PREFIX: &[u8; 3] = b"FGL";
const MAGIC_V1: &[u8; 4] = b"FGL1";
const MAGIC_V2: &[u8; 4] = b"FGL2";
/// Bytes of version 2's checksum, at the end of the file.
const CHECKSUM_BYTES: usize = 4;
/// Entries of all contexts' code tables: context << 8 | symbol.
const CODED: usize = MAX_CONTEXTS * SYMBOLS;
/// Entries of all contexts' decoding tables: context << MAX_CODE_BITS | next bits.
const DECODING: usize = MAX_CONTEXTS << MAX_CODE_BITS;
/// Entries of the activity-to-context table (a power of two above [`MAX_ACTIVITY`]).
const ACTIVITIES: usize = 1024;
const SYMBOLS: usize = 256;
/// Highest activity: three differences of 8-bit values.
const MAX_ACTIVITY: usize = 3 * 255;

/// How the colours of the image lie.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pattern {
    /// Every pixel the same colour (Mono8).
    Mono,
    /// A 2x2 colour mosaic (BayerRG8 and its kin): same colours two pixels apart.
    Mosaic2x2,
}

impl Pattern {
    fn step(self) -> usize {
        match self {
            Pattern::Mono => 1,
            Pattern::Mosaic2x2 => 2,
        }
    }
}

/// An image read back.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GreyImage {
    pub width: u32,
    pub height: u32,
    pub pattern: Pattern,
    pub pixels: Vec<u8>,
}

/// Why bytes are not an FGL image.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CodecError {
    #[error("not an FGL image (it does not start with \"FGL1\" or \"FGL2\")")]
    NotFgl,
    #[error(
        "an FGL image of version {0}, written by a newer fringe (this one reads versions 1 and \
         2): read it with a newer fringe"
    )]
    Newer(char),
    #[error(
        "the FGL image is damaged: its checksum does not match its bytes (changed or cut short \
         on the disk or in a copy since it was written); restore it from a backup"
    )]
    Checksum,
    #[error("the FGL image is cut short ({0})")]
    Truncated(&'static str),
    #[error("the FGL image is damaged: {0}")]
    Damaged(String),
    #[error("{width}x{height} px is too large for an FGL image (at most {MAX_PIXELS} px)")]
    TooLarge { width: u32, height: u32 },
    #[error("{pixels} bytes are not a {width}x{height} image")]
    WrongSize {
        width: u32,
        height: u32,
        pixels: usize,
    },
}

/// Encodes a `width` x `height` one-channel image.
pub fn encode(
    pixels: &[u8],
    width: u32,
    height: u32,
    pattern: Pattern,
) -> Result<Vec<u8>, CodecError> {
    let (w, h) = (width as usize, height as usize);
    if u64::from(width) * u64::from(height) > MAX_PIXELS {
        return Err(CodecError::TooLarge { width, height });
    }
    if pixels.len() != w * h {
        return Err(CodecError::WrongSize {
            width,
            height,
            pixels: pixels.len(),
        });
    }
    let s = pattern.step();
    let mut row = vec![0u16; w];

    // The activity thresholds, from an eighth of the rows (two of every sixteen, so that both
    // rows of a mosaic count: no more bytes than from a quarter, measured); then each context's
    // symbol counts over the whole image (counts from a sample would have to give every unseen
    // symbol a code, which costs 3 % of the bytes at 12 bits a code at most).
    let sampled = |y: usize| y % 16 < 2;
    let mut histogram = [0u64; ACTIVITIES];
    let mut sampled_px = 0u64;
    for y in (s..h).filter(|&y| sampled(y)) {
        map_row(pixels, w, y, s, &mut row, |_, a| a);
        for &a in &row {
            histogram[usize::from(a) & (ACTIVITIES - 1)] += 1;
        }
        sampled_px += w as u64;
    }
    let thresholds = thresholds_for(&histogram, sampled_px);
    let contexts = thresholds.len() + 1;
    let bounds = bounds_of(&thresholds);
    // Each pixel as its context and symbol, context << 8 | symbol: the index of its code.
    let coded = move |v: u8, a: u16| context_of(a, &bounds) << 8 | u16::from(v);
    // Counted in two halves, even and odd columns, so that a run of one symbol does not wait on
    // its own count (measured on an earlier version of this encoder: one array 10-11 ms a whole
    // frame, two 8.8 ms, four no faster).
    let mut counts = [0u32; CODED];
    let mut odd = [0u32; CODED];
    // The buffers of the last image encoded on this thread, reused: a recording encodes one
    // frame after another, and fresh buffers cost their pages again each time (measured: 1 ms
    // of 6 a whole frame).
    let Scratch {
        coded: mut all,
        bits: mut payload,
    } = SCRATCH.with(|s| s.take());
    all.resize(w * h, 0);
    for (y, row) in all.chunks_exact_mut(w.max(1)).enumerate() {
        map_row(pixels, w, y, s, row, coded);
        for pair in row.chunks_exact(2) {
            counts[usize::from(pair[0]) & (CODED - 1)] += 1;
            odd[usize::from(pair[1]) & (CODED - 1)] += 1;
        }
        if w % 2 == 1 {
            counts[usize::from(row[w - 1]) & (CODED - 1)] += 1;
        }
    }
    for (c, o) in counts.iter_mut().zip(odd) {
        *c += o;
    }
    let lengths: Vec<[u8; SYMBOLS]> = counts[..contexts * SYMBOLS]
        .chunks_exact(SYMBOLS)
        .map(|c| limited_lengths(c, MAX_CODE_BITS))
        .collect();
    let mut codes = [0u32; CODED];
    for (k, l) in lengths.iter().enumerate() {
        for (sym, (code, len)) in canonical_codes(l).into_iter().enumerate() {
            codes[k * SYMBOLS + sym] = code | u32::from(len) << 16;
        }
    }

    // The codes, pixel by pixel, least significant bit first, four at a time (at most 7 + 4 x 12
    // bits held): each group's bits are stored as a whole word and the position moves on by
    // the full bytes. Four codes are joined before they meet the accumulator, so that each
    // group waits on the previous one only once.
    let most = (w * h * MAX_CODE_BITS as usize).div_ceil(8) + 8;
    if payload.len() < most {
        payload.resize(most, 0);
    }
    let stream = &mut payload;
    let mut at = 0;
    let mut acc: u64 = 0;
    let mut bits: u32 = 0;
    let code = |c: u16| -> (u64, u32) {
        let entry = codes[usize::from(c) & (CODED - 1)];
        (u64::from(entry & 0xffff), entry >> 16)
    };
    for c in all.chunks_exact(4) {
        let ((c0, l0), (c1, l1)) = (code(c[0]), code(c[1]));
        let ((c2, l2), (c3, l3)) = (code(c[2]), code(c[3]));
        let low = c0 | c1 << l0;
        let high = c2 | c3 << l2;
        acc |= (low | high << (l0 + l1)) << bits;
        bits += l0 + l1 + l2 + l3;
        stream[at..at + 8].copy_from_slice(&acc.to_le_bytes());
        let whole = bits >> 3;
        at += whole as usize;
        // At most 55 bits were held: `whole` is at most 6.
        acc >>= 8 * whole;
        bits &= 7;
    }
    for &c in all.chunks_exact(4).remainder() {
        let (c, l) = code(c);
        acc |= c << bits;
        bits += l;
    }
    // At most 7 + 3 x 12 bits are held.
    stream[at..at + 8].copy_from_slice(&acc.to_le_bytes());
    let used = at + bits.div_ceil(8) as usize;

    let mut out = Vec::with_capacity(
        HEADER_BYTES + 1 + 2 * MAX_CONTEXTS + contexts * SYMBOLS / 2 + used + CHECKSUM_BYTES,
    );
    out.extend_from_slice(MAGIC_V2);
    out.extend_from_slice(&width.to_le_bytes());
    out.extend_from_slice(&height.to_le_bytes());
    out.push(match pattern {
        Pattern::Mono => 0,
        Pattern::Mosaic2x2 => 1,
    });
    out.push(contexts as u8);
    for t in &thresholds {
        out.extend_from_slice(&t.to_le_bytes());
    }
    for l in &lengths {
        for pair in l.chunks_exact(2) {
            out.push(pair[0] | pair[1] << 4);
        }
    }

    out.extend_from_slice(&payload[..used]);
    let checksum = crc32fast::hash(&out);
    out.extend_from_slice(&checksum.to_le_bytes());
    // Kept for camera frames; an unusually large image's buffers go.
    if all.len() <= KEEP_PIXELS {
        SCRATCH.with(|s| {
            s.set(Scratch {
                coded: all,
                bits: payload,
            })
        });
    }
    Ok(out)
}

/// Largest image whose buffers an encoding thread keeps for the next (about 60 MB of them).
const KEEP_PIXELS: usize = 16 << 20;

/// An encoder's buffers, kept from one image to the next on each thread.
#[derive(Default)]
struct Scratch {
    /// Each pixel's code index, context << 8 | symbol.
    coded: Vec<u16>,
    /// The payload's bits (as long as the longest possible payload).
    bits: Vec<u8>,
}

thread_local! {
    static SCRATCH: std::cell::Cell<Scratch> = std::cell::Cell::new(Scratch::default());
}

/// The version an FGL file's first bytes name (1 or 2).
fn version(bytes: &[u8]) -> Result<u8, CodecError> {
    match bytes.get(..4) {
        Some(m) if m == MAGIC_V1 => Ok(1),
        Some(m) if m == MAGIC_V2 => Ok(2),
        Some(m) if &m[..3] == MAGIC_PREFIX && (b'3'..=b'9').contains(&m[3]) => {
            Err(CodecError::Newer(char::from(m[3])))
        }
        Some(_) => Err(CodecError::NotFgl),
        None if !MAGIC_PREFIX.starts_with(&bytes[..bytes.len().min(3)]) => Err(CodecError::NotFgl),
        None => Err(CodecError::Truncated("header")),
    }
}

/// The width, height and pattern an FGL file's first [`HEADER_BYTES`] bytes name (the header
/// is the same in every version).
pub fn header(bytes: &[u8]) -> Result<(u32, u32, Pattern), CodecError> {
    version(bytes)?;
    let head = bytes
        .get(..HEADER_BYTES)
        .ok_or(CodecError::Truncated("header"))?;
    let width = u32::from_le_bytes([head[4], head[5], head[6], head[7]]);
    let height = u32::from_le_bytes([head[8], head[9], head[10], head[11]]);
    if u64::from(width) * u64::from(height) > MAX_PIXELS {
        return Err(CodecError::TooLarge { width, height });
    }
    let pattern = match head[12] {
        0 => Pattern::Mono,
        1 => Pattern::Mosaic2x2,
        other => {
            return Err(CodecError::Damaged(format!(
                "unknown colour pattern {other}"
            )))
        }
    };
    Ok((width, height, pattern))
}

/// The bytes before a version-2 file's checksum, once the checksum matches them (a version-1
/// file, which has none, as it is). A cut-short file is said to be cut short.
fn checked_body(bytes: &[u8]) -> Result<&[u8], CodecError> {
    if version(bytes)? == 1 {
        return Ok(bytes);
    }
    header(bytes)?;
    let Some(at) = bytes.len().checked_sub(CHECKSUM_BYTES) else {
        return Err(CodecError::Truncated("checksum"));
    };
    let (body, stored) = bytes.split_at(at);
    let stored = u32::from_le_bytes([stored[0], stored[1], stored[2], stored[3]]);
    if crc32fast::hash(body) == stored {
        return Ok(body);
    }
    // The checksum tells that the file changed, not how: one too short to hold its own tables
    // is cut short; past them, a cut and a changed bit look alike.
    match decode_body(body) {
        Err(e @ CodecError::Truncated(what)) if what != "pixels" => Err(e),
        _ => Err(CodecError::Checksum),
    }
}

/// Checks an FGL file without keeping its pixels: a file of version 2 by its checksum (fast),
/// one of version 1, which has none, by decoding it whole.
pub(crate) fn check(bytes: &[u8]) -> Result<(), CodecError> {
    let body = checked_body(bytes)?;
    if version(bytes)? == 1 {
        decode_body(body)?;
    }
    Ok(())
}

/// Decodes an image written by [`encode`] (version 2), or by the encoder of version 1.
pub fn decode(bytes: &[u8]) -> Result<GreyImage, CodecError> {
    decode_body(checked_body(bytes)?)
}

/// Decodes the header, tables and pixels of a file, of either version (its checksum, if any,
/// checked and cut off).
fn decode_body(bytes: &[u8]) -> Result<GreyImage, CodecError> {
    let (width, height, pattern) = header(bytes)?;
    let mut at = HEADER_BYTES;
    let mut take = |n: usize, what: &'static str| -> Result<&[u8], CodecError> {
        let part = bytes.get(at..at + n).ok_or(CodecError::Truncated(what))?;
        at += n;
        Ok(part)
    };
    let contexts = usize::from(take(1, "header")?[0]);
    if !(1..=MAX_CONTEXTS).contains(&contexts) {
        return Err(CodecError::Damaged(format!(
            "{contexts} contexts (1 to {MAX_CONTEXTS} are possible)"
        )));
    }
    let mut thresholds = Vec::with_capacity(contexts - 1);
    for pair in take(2 * (contexts - 1), "thresholds")?.chunks_exact(2) {
        thresholds.push(u16::from_le_bytes([pair[0], pair[1]]));
    }
    if thresholds.windows(2).any(|t| t[0] >= t[1]) || thresholds.first() == Some(&0) {
        return Err(CodecError::Damaged(
            "the activity thresholds are not ascending".into(),
        ));
    }
    let packed = take(contexts * SYMBOLS / 2, "code lengths")?;
    let table_size = 1usize << MAX_CODE_BITS;
    let mut table: Box<[u16; DECODING]> = vec![0u16; DECODING]
        .into_boxed_slice()
        .try_into()
        .map_err(|_| CodecError::Damaged("decoding table".into()))?;
    for (k, lengths) in packed.chunks_exact(SYMBOLS / 2).enumerate() {
        let mut l = [0u8; SYMBOLS];
        for (i, &b) in lengths.iter().enumerate() {
            l[2 * i] = b & 0xf;
            l[2 * i + 1] = b >> 4;
        }
        fill_decode_table(&l, &mut table[k * table_size..(k + 1) * table_size], k)?;
    }
    let lut = context_lut(&thresholds);
    // Every pixel takes at least one bit: a payload too short for the size is refused before
    // the image is allocated.
    if (bytes.len() - at) as u64 * 8 < u64::from(width) * u64::from(height) {
        return Err(CodecError::Truncated("pixels"));
    }
    let mut reader = BitReader::new(&bytes[at..]);
    let (w, h) = (width as usize, height as usize);
    let mut pixels = vec![0u8; w * h];
    match pattern {
        Pattern::Mono => decode_rows::<1>(&mut pixels, w, &table, &lut, &mut reader)?,
        Pattern::Mosaic2x2 => decode_rows::<2>(&mut pixels, w, &table, &lut, &mut reader)?,
    }
    reader.check()?;
    Ok(GreyImage {
        width,
        height,
        pattern,
        pixels,
    })
}

/// Decodes the rows of an image whose same-colour neighbours are `S` pixels apart. The reader
/// notes a fault instead of stopping on it; it is looked at once per row.
fn decode_rows<const S: usize>(
    pixels: &mut [u8],
    w: usize,
    table: &[u16; DECODING],
    lut: &[u8; ACTIVITIES],
    reader: &mut BitReader,
) -> Result<(), CodecError> {
    if w == 0 {
        return Ok(());
    }
    let last = usize::from(lut[MAX_ACTIVITY]) << MAX_CODE_BITS;
    let h = pixels.len() / w;
    for row in pixels.chunks_exact_mut(w).take(S) {
        for x in 0..w {
            let pred = if x < S { 128 } else { row[x - S] };
            row[x] = pred.wrapping_add(unfold(reader.symbol(table, last)));
        }
        reader.check()?;
    }
    for y in S..h {
        let (done, rest) = pixels.split_at_mut(y * w);
        let cur = &mut rest[..w];
        let above = &done[(y - S) * w..(y - S + 1) * w];
        let mut decode_at = |n: i32, wv: i32, nw: i32, ne: i32| -> u8 {
            let (pred, a) = predict([wv, n, nw, ne]);
            let base = usize::from(lut[a & (ACTIVITIES - 1)]) << MAX_CODE_BITS;
            pred.wrapping_add(unfold(reader.symbol(table, base)))
        };
        if w <= 2 * S {
            for x in 0..w {
                let [wv, n, nw, ne] = neighbours(cur, above, x, S);
                cur[x] = decode_at(n, wv, nw, ne);
            }
            reader.check()?;
            continue;
        }
        // The left edge: W and NW are N.
        for x in 0..S {
            let n = i32::from(above[x]);
            cur[x] = decode_at(n, n, n, i32::from(above[x + S]));
        }
        // The interior: each window of the row above is NW .. N .. NE, and the last S pixels
        // decoded are kept at hand (W is the oldest).
        let mut recent = [0i32; S];
        for (r, &v) in recent.iter_mut().zip(cur.iter()) {
            *r = i32::from(v);
        }
        for (window, out) in above.windows(2 * S + 1).zip(cur[S..w - S].iter_mut()) {
            let v = decode_at(
                i32::from(window[S]),
                recent[0],
                i32::from(window[0]),
                i32::from(window[2 * S]),
            );
            *out = v;
            recent.copy_within(1.., 0);
            recent[S - 1] = i32::from(v);
        }
        // The right edge: NE is N.
        for x in w - S..w {
            let n = i32::from(above[x]);
            cur[x] = decode_at(n, i32::from(cur[x - S]), i32::from(above[x - S]), n);
        }
        reader.check()?;
    }
    Ok(())
}

/// The same-colour neighbours (W, N, NW, NE) of pixel `x` of `cur`, `s` pixels apart, with
/// `above` the row `s` above: past the left or right edge, N stands in.
#[inline(always)]
fn neighbours(cur: &[u8], above: &[u8], x: usize, s: usize) -> [i32; 4] {
    let n = i32::from(above[x]);
    let (wv, nw) = if x >= s {
        (i32::from(cur[x - s]), i32::from(above[x - s]))
    } else {
        (n, n)
    };
    let ne = if x + s < cur.len() {
        i32::from(above[x + s])
    } else {
        n
    };
    [wv, n, nw, ne]
}

/// The prediction and the activity from the neighbours W, N, NW, NE (the vectorised interior of
/// [`map_row`] computes the same in 16 bits).
#[inline(always)]
fn predict([wv, n, nw, ne]: [i32; 4]) -> (u8, usize) {
    let pred = ((wv + n + nw + ne + 2) >> 2) as u8;
    let a = (n - nw).abs() + (ne - n).abs() + (wv - nw).abs();
    (pred, a as usize)
}

/// Row `y`'s pixels, each mapped by `f` from its symbol and its activity into `out`: the
/// interior of the row is written so that the compiler can vectorise it, `f` with it. The first
/// `s` rows are predicted from the left neighbour of the same colour, with the highest activity.
#[inline(always)]
fn map_row<F: Fn(u8, u16) -> u16>(
    pixels: &[u8],
    w: usize,
    y: usize,
    s: usize,
    out: &mut [u16],
    f: F,
) {
    let cur = &pixels[y * w..(y + 1) * w];
    if y < s {
        for x in 0..w {
            let pred = if x < s { 128 } else { cur[x - s] };
            out[x] = f(fold(cur[x].wrapping_sub(pred)), MAX_ACTIVITY as u16);
        }
        return;
    }
    let above = &pixels[(y - s) * w..(y - s + 1) * w];
    let one = |x: usize| -> u16 {
        let (pred, a) = predict(neighbours(cur, above, x, s));
        f(fold(cur[x].wrapping_sub(pred)), a as u16)
    };
    if w <= 2 * s {
        for (x, o) in out.iter_mut().enumerate() {
            *o = one(x);
        }
        return;
    }
    for x in (0..s).chain(w - s..w) {
        out[x] = one(x);
    }
    let inner = w - 2 * s;
    let left = &cur[..inner];
    let centre = &cur[s..s + inner];
    let up_left = &above[..inner];
    let up = &above[s..s + inner];
    let up_right = &above[2 * s..2 * s + inner];
    let out = &mut out[s..s + inner];
    for i in 0..inner {
        let (wv, n, nw, ne) = (
            i16::from(left[i]),
            i16::from(up[i]),
            i16::from(up_left[i]),
            i16::from(up_right[i]),
        );
        let pred = ((wv + n + nw + ne + 2) >> 2) as u8;
        let a = ((n - nw).abs() + (ne - n).abs() + (wv - nw).abs()) as u16;
        out[i] = f(fold(centre[i].wrapping_sub(pred)), a);
    }
}

/// A residual (modulo 256) as a symbol: 0, -1, 1, -2, 2, ... as 0, 1, 2, 3, 4, ...
fn fold(r: u8) -> u8 {
    let r = r as i8;
    ((r << 1) ^ (r >> 7)) as u8
}

fn unfold(s: u8) -> u8 {
    (s >> 1) ^ (s & 1).wrapping_neg()
}

/// Activity thresholds that split `total` pixels whose activities are counted in `histogram`
/// into up to [`MAX_CONTEXTS`] groups of about equal count (ascending, distinct, none zero).
fn thresholds_for(histogram: &[u64], total: u64) -> Vec<u16> {
    let mut thresholds: Vec<u16> = Vec::with_capacity(MAX_CONTEXTS - 1);
    let mut below = 0u64;
    let mut next = 1;
    for (a, &n) in histogram.iter().enumerate() {
        // `a` starts a new group once the pixels below it reach the next share.
        while next < MAX_CONTEXTS && below * MAX_CONTEXTS as u64 >= next as u64 * total.max(1) {
            if a > 0 && thresholds.last() != Some(&(a as u16)) {
                thresholds.push(a as u16);
            }
            next += 1;
        }
        below += n;
    }
    thresholds
}

/// The thresholds padded to [`MAX_CONTEXTS`] - 1 with one that no activity reaches (as `i16`,
/// which compare in one instruction when vectorised: thresholds above [`MAX_ACTIVITY`] count
/// as unreachable).
fn bounds_of(thresholds: &[u16]) -> [i16; MAX_CONTEXTS - 1] {
    std::array::from_fn(|k| {
        thresholds
            .get(k)
            .map_or(i16::MAX, |&t| t.min(MAX_ACTIVITY as u16 + 1) as i16)
    })
}

/// The context of activity `a`: how many of the thresholds it reaches.
#[inline(always)]
fn context_of(a: u16, bounds: &[i16; MAX_CONTEXTS - 1]) -> u16 {
    let a = a as i16;
    let mut context = 0;
    for &t in bounds {
        context += u16::from(a >= t);
    }
    context
}

/// The context of each activity.
fn context_lut(thresholds: &[u16]) -> [u8; ACTIVITIES] {
    let bounds = bounds_of(thresholds);
    std::array::from_fn(|a| context_of(a as u16, &bounds) as u8)
}

/// Huffman code lengths of at most `limit` bits for symbols counted `counts` (0: absent): the
/// Huffman code's lengths, with codes longer than the limit brought up as JPEG's annex K.3
/// does (two leaves of the deepest level become one leaf a level up and one beside the
/// deepest leaf above the limit's reach), then dealt to the symbols from the most counted on.
fn limited_lengths(counts: &[u32], limit: u32) -> [u8; SYMBOLS] {
    let weights: Vec<u64> = counts.iter().map(|&c| u64::from(c)).collect();
    let lengths = huffman_lengths(&weights);
    let limit = limit as usize;
    let deepest = usize::from(lengths.iter().copied().max().unwrap_or(0));
    if deepest <= limit {
        return lengths;
    }
    let mut per_length = vec![0usize; deepest + 1];
    for &l in lengths.iter().filter(|&&l| l > 0) {
        per_length[usize::from(l)] += 1;
    }
    for i in (limit + 1..=deepest).rev() {
        while per_length[i] > 0 {
            let mut j = i - 2;
            while per_length[j] == 0 {
                j -= 1;
            }
            per_length[i] -= 2;
            per_length[i - 1] += 1;
            per_length[j + 1] += 2;
            per_length[j] -= 1;
        }
    }
    let mut order: Vec<usize> = (0..SYMBOLS.min(counts.len()))
        .filter(|&s| counts[s] > 0)
        .collect();
    order.sort_by_key(|&s| (std::cmp::Reverse(counts[s]), s));
    let mut limited = [0u8; SYMBOLS];
    let mut symbols = order.into_iter();
    for (len, &n) in per_length.iter().enumerate().take(limit + 1) {
        for s in symbols.by_ref().take(n) {
            limited[s] = len as u8;
        }
    }
    limited
}

/// Huffman code lengths; a lone symbol gets 1 bit.
fn huffman_lengths(weights: &[u64]) -> [u8; SYMBOLS] {
    use std::cmp::Reverse;
    use std::collections::BinaryHeap;
    let mut lengths = [0u8; SYMBOLS];
    let used: Vec<usize> = (0..weights.len()).filter(|&i| weights[i] > 0).collect();
    if used.len() == 1 {
        lengths[used[0]] = 1;
        return lengths;
    }
    // Nodes: leaves first, then merged; each node's parent.
    let mut parent = vec![usize::MAX; 2 * used.len()];
    let mut heap: BinaryHeap<Reverse<(u64, usize)>> = used
        .iter()
        .enumerate()
        .map(|(node, &sym)| Reverse((weights[sym], node)))
        .collect();
    let mut next = used.len();
    while heap.len() > 1 {
        let (Some(Reverse((wa, a))), Some(Reverse((wb, b)))) = (heap.pop(), heap.pop()) else {
            break;
        };
        parent[a] = next;
        parent[b] = next;
        heap.push(Reverse((wa + wb, next)));
        next += 1;
    }
    for (leaf, &sym) in used.iter().enumerate() {
        let mut depth = 0u8;
        let mut node = leaf;
        while parent[node] != usize::MAX {
            node = parent[node];
            depth += 1;
        }
        lengths[sym] = depth;
    }
    lengths
}

/// Canonical codes for `lengths`, bit-reversed for a least-significant-bit-first stream:
/// (code, length) per symbol.
fn canonical_codes(lengths: &[u8; SYMBOLS]) -> Vec<(u32, u8)> {
    let mut order: Vec<usize> = (0..SYMBOLS).filter(|&s| lengths[s] > 0).collect();
    order.sort_by_key(|&s| (lengths[s], s));
    let mut codes = vec![(0u32, 0u8); SYMBOLS];
    let mut code = 0u32;
    let mut previous = 0u8;
    for s in order {
        let len = lengths[s];
        code <<= len - previous;
        previous = len;
        codes[s] = (reverse(code, len), len);
        code += 1;
    }
    codes
}

fn reverse(code: u32, len: u8) -> u32 {
    code.reverse_bits() >> (32 - u32::from(len))
}

/// The decoding table of one context: for each next [`MAX_CODE_BITS`] bits, symbol << 4 | length
/// (length 0: no code starts so). Refuses lengths that are no prefix code.
fn fill_decode_table(
    lengths: &[u8; SYMBOLS],
    table: &mut [u16],
    context: usize,
) -> Result<(), CodecError> {
    let space: u64 = lengths
        .iter()
        .filter(|&&l| l > 0)
        .map(|&l| 1u64 << (MAX_CODE_BITS - u32::from(l.min(MAX_CODE_BITS as u8))))
        .sum();
    if lengths.iter().any(|&l| u32::from(l) > MAX_CODE_BITS) || space > 1 << MAX_CODE_BITS {
        return Err(CodecError::Damaged(format!(
            "the code lengths of context {context} are no prefix code"
        )));
    }
    for (sym, (code, len)) in canonical_codes(lengths).into_iter().enumerate() {
        if len == 0 {
            continue;
        }
        let entry = (sym as u16) << 4 | u16::from(len);
        let mut k = code as usize;
        while k < table.len() {
            table[k] = entry;
            k += 1 << len;
        }
    }
    Ok(())
}

/// Reads codes least significant bit first from a copy of the payload padded with zeros, a
/// word at a time. A code past the end of the payload or one that no table holds is noted, and
/// reading goes on on zeros; [`BitReader::check`] reports it.
struct BitReader {
    bytes: Vec<u8>,
    /// Payload length, bytes.
    len: usize,
    /// Bits used.
    position: usize,
    /// The next bits, from `position` on.
    peek: u64,
    /// Valid bits in `peek`.
    held: u32,
    /// A code that no table holds was met.
    no_code: bool,
}

impl BitReader {
    fn new(payload: &[u8]) -> BitReader {
        let mut bytes = Vec::with_capacity(payload.len() + 16);
        bytes.extend_from_slice(payload);
        bytes.resize(payload.len() + 16, 0);
        BitReader {
            bytes,
            len: payload.len(),
            position: 0,
            peek: 0,
            held: 0,
            no_code: false,
        }
    }

    /// The next symbol, by the decoding table of the context starting at `base`.
    #[inline(always)]
    fn symbol(&mut self, table: &[u16; DECODING], base: usize) -> u8 {
        if self.held < MAX_CODE_BITS {
            // Past the end, the word read is the padding's zeros.
            let byte = (self.position >> 3).min(self.len);
            let word = &self.bytes[byte..byte + 8];
            let word = u64::from_le_bytes([
                word[0], word[1], word[2], word[3], word[4], word[5], word[6], word[7],
            ]);
            let skip = (self.position & 7) as u32;
            self.peek = word >> skip;
            self.held = 64 - skip;
        }
        let next = self.peek as usize & ((1 << MAX_CODE_BITS) - 1);
        let entry = table[(base | next) & (DECODING - 1)];
        let mut len = u32::from(entry & 0xf);
        if len == 0 {
            self.no_code = true;
            len = 1;
        }
        self.peek >>= len;
        self.held -= len;
        self.position += len as usize;
        (entry >> 4) as u8
    }

    /// Fails when a code was not in its table or the codes ran past the end of the payload.
    fn check(&self) -> Result<(), CodecError> {
        if self.no_code {
            return Err(CodecError::Damaged("a code that no table holds".into()));
        }
        if self.position > 8 * self.len {
            return Err(CodecError::Truncated("pixels"));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic noisy image with fringes: what the codec is for.
    fn fringes(w: usize, h: usize, seed: u64) -> Vec<u8> {
        let mut state = seed | 1;
        (0..w * h)
            .map(|i| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                let r = ((x - w as f64 / 2.0).powi(2) + (y - h as f64 / 2.0).powi(2)).sqrt();
                let v = 110.0 + 40.0 * (r / 12.0).sin() + (state % 9) as f64 - 4.0;
                v.clamp(0.0, 255.0) as u8
            })
            .collect()
    }

    /// `bytes` (a version-2 file changed) with its checksum made to match again.
    fn resealed(mut bytes: Vec<u8>) -> Vec<u8> {
        let at = bytes.len() - CHECKSUM_BYTES;
        let crc = crc32fast::hash(&bytes[..at]);
        bytes[at..].copy_from_slice(&crc.to_le_bytes());
        bytes
    }

    /// The same image in version 1: its magic, no checksum (the old encoder's bytes, as the
    /// fixture shows).
    fn version_1(bytes: &[u8]) -> Vec<u8> {
        let mut old = bytes[..bytes.len() - CHECKSUM_BYTES].to_vec();
        old[..4].copy_from_slice(MAGIC_V1);
        old
    }

    #[test]
    fn every_bit_flipped_in_a_new_file_is_found_and_called_damage() {
        let pixels = fringes(24, 16, 9);
        let bytes = encode(&pixels, 24, 16, Pattern::Mosaic2x2).expect("encode");
        assert_eq!(&bytes[..4], b"FGL2");
        // Past the header (whose damage is refused as such: another size, not an FGL file).
        for bit in HEADER_BYTES * 8..bytes.len() * 8 {
            let mut flipped = bytes.clone();
            flipped[bit / 8] ^= 1 << (bit % 8);
            let e = decode(&flipped).expect_err("a flipped bit");
            assert!(
                matches!(e, CodecError::Checksum | CodecError::Truncated(_)),
                "bit {bit}: {e}"
            );
            assert!(check(&flipped).is_err(), "bit {bit}");
        }
        let mut flipped = bytes.clone();
        flipped[bytes.len() / 2] ^= 0x10;
        assert_eq!(decode(&flipped), Err(CodecError::Checksum));
        assert!(CodecError::Checksum.to_string().contains("checksum"));
        assert_eq!(check(&bytes), Ok(()));
    }

    #[test]
    fn files_of_version_1_written_by_the_old_encoder_still_decode() {
        // Written by the encoder before version 2 (rig/fixtures/README.md).
        let old = include_bytes!("../../../fixtures/fgl1-12x8-mosaic.fgl");
        let want = include_bytes!("../../../fixtures/fgl1-12x8-mosaic.pixels");
        assert_eq!(&old[..4], b"FGL1");
        assert_eq!(header(old), Ok((12, 8, Pattern::Mosaic2x2)));
        let back = decode(old).expect("a version-1 file");
        assert_eq!((back.width, back.height), (12, 8));
        assert_eq!(back.pixels, want.to_vec());
        assert_eq!(check(old), Ok(()));
        // Today's encoder writes the same image as the old one did, with a checksum added.
        let new = encode(want, 12, 8, Pattern::Mosaic2x2).expect("encode");
        assert_eq!(version_1(&new), old.to_vec());
        let pixels = fringes(33, 21, 4);
        let v1 = version_1(&encode(&pixels, 33, 21, Pattern::Mono).expect("encode"));
        assert_eq!(decode(&v1).expect("version 1").pixels, pixels);
        // A later version is refused by name.
        let mut later = encode(want, 12, 8, Pattern::Mosaic2x2).expect("encode");
        later[3] = b'3';
        let e = decode(&later).expect_err("version 3");
        assert_eq!(e, CodecError::Newer('3'));
        assert!(e.to_string().contains("newer fringe"), "{e}");
    }

    fn round_trip(pixels: &[u8], w: u32, h: u32, pattern: Pattern) -> usize {
        let bytes = encode(pixels, w, h, pattern).expect("encode");
        let back = decode(&bytes).expect("decode");
        assert_eq!((back.width, back.height, back.pattern), (w, h, pattern));
        assert!(back.pixels == pixels, "{w}x{h} {pattern:?} differs");
        bytes.len()
    }

    #[test]
    fn every_pixel_comes_back_at_every_size_and_pattern() {
        for pattern in [Pattern::Mono, Pattern::Mosaic2x2] {
            for (w, h) in [
                (0, 0),
                (1, 1),
                (1, 7),
                (7, 1),
                (2, 2),
                (3, 5),
                (5, 3),
                (64, 48),
            ] {
                round_trip(&fringes(w, h, 3), w as u32, h as u32, pattern);
            }
        }
    }

    #[test]
    fn extremes_and_flat_images_come_back() {
        // Residuals of every size: alternating black and white, with steps of every height.
        let (w, h) = (37usize, 23usize);
        let harsh: Vec<u8> = (0..w * h)
            .map(|i| {
                if (i * 7919) % 3 == 0 {
                    255
                } else {
                    (i * 31 % 256) as u8
                }
            })
            .collect();
        let flat = vec![77u8; w * h];
        for pattern in [Pattern::Mono, Pattern::Mosaic2x2] {
            round_trip(&harsh, w as u32, h as u32, pattern);
            round_trip(&flat, w as u32, h as u32, pattern);
        }
        // Every byte value, in a random order: symbols whose counts need the length limit.
        let mut skewed = Vec::new();
        for v in 0..=255u8 {
            let copies = 1usize << (v / 16);
            skewed.extend(std::iter::repeat_n(v, copies.min(1 << 12)));
        }
        let n = skewed.len() as u32;
        round_trip(&skewed, n, 1, Pattern::Mono);
    }

    #[test]
    fn noisy_fringes_take_fewer_bytes_than_their_pixels() {
        let (w, h) = (256usize, 192usize);
        let pixels = fringes(w, h, 11);
        let n = round_trip(&pixels, w as u32, h as u32, Pattern::Mono);
        // Noise of 9 levels has 3.17 bits of entropy: the code must come close (< 4.5 bits).
        assert!(n * 8 < w * h * 9 / 2, "{n} bytes for {} px", w * h);
    }

    #[test]
    fn code_lengths_stay_within_the_limit_and_form_a_prefix_code() {
        let counts: Vec<u32> = (0..256).map(|i| 1u32 << (i / 10).min(30)).collect();
        let lengths = limited_lengths(&counts, MAX_CODE_BITS);
        assert!(lengths.iter().all(|&l| (1..=12).contains(&l)));
        let kraft: f64 = lengths.iter().map(|&l| 0.5f64.powi(i32::from(l))).sum();
        assert!(kraft <= 1.0 + 1e-12, "{kraft}");
        let mut table = vec![0u16; 1 << MAX_CODE_BITS];
        fill_decode_table(&lengths, &mut table, 0).expect("a prefix code");
    }

    #[test]
    fn damaged_or_short_files_are_errors_not_garbage() {
        let pixels = fringes(40, 30, 5);
        let bytes = encode(&pixels, 40, 30, Pattern::Mosaic2x2).expect("encode");
        assert_eq!(decode(b"\x89PNG\r\n\x1a\n"), Err(CodecError::NotFgl));
        for cut in [3, 10, 13, 20, 200] {
            assert!(
                matches!(decode(&bytes[..cut]), Err(CodecError::Truncated(_))),
                "cut at {cut}: {:?}",
                decode(&bytes[..cut]).map(|_| ())
            );
        }
        // Cut in the pixels: the checksum finds it (version 1 has none: the pixels run out).
        assert_eq!(
            decode(&bytes[..bytes.len() - 40]),
            Err(CodecError::Checksum)
        );
        let old = version_1(&bytes);
        assert!(matches!(
            decode(&old[..old.len() - 40]),
            Err(CodecError::Truncated(_))
        ));
        let mut big = bytes.clone();
        big[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(matches!(decode(&big), Err(CodecError::TooLarge { .. })));
        let mut lengths = bytes.clone();
        // Every symbol of context 0 one bit long: no prefix code (written so, checksum and
        // all, as a faulty encoder would).
        let at = 14 + 2 * (usize::from(bytes[13]) - 1);
        lengths[at..at + 128].fill(0x11);
        assert!(matches!(
            decode(&resealed(lengths)),
            Err(CodecError::Damaged(_))
        ));
        // Flipped bits anywhere (header, thresholds, code lengths, payload) decode to other
        // pixels or fail; never panic.
        for k in (0..bytes.len()).step_by(7) {
            let mut flipped = bytes.clone();
            flipped[k] ^= 0x5a;
            let _ = decode(&flipped);
        }
        assert!(matches!(
            encode(&pixels, 41, 30, Pattern::Mono),
            Err(CodecError::WrongSize { .. })
        ));
    }
}
