//! Reading an image file within bounds: the one way every crate reads a PNG or JPEG from
//! disk, and the one pixel limit every decoder is held to (docs/errors.md, "Bad input").
//!
//! A decoder told nothing about its input allocates what the file's header asks for, and
//! `std::fs::read` reads whatever the path gives: `/dev/zero` until memory runs out, a
//! sparse file of gigabytes before its second chunk is looked at. So the header is read
//! first (PNG `IHDR`, JPEG `SOFn`), without reading the rest; the declared size is checked
//! against [`max_image_pixels`]; and the file is read only if its length fits what an
//! image of that size can take. This lives in `fileio`, the one crate below everything
//! that reads images (`tables`' structural check, `features`' decoders, ingest, the shard
//! stage, `pl2map localize`), so that the limit has one definition.
//!
//! Refusals are `io::Error`s inside [`IoError`] (the path named), told apart by kind:
//! [`ErrorKind::InvalidData`] for a damaged or mislabelled file,
//! [`ErrorKind::FileTooLarge`] for an image over the pixel limit,
//! [`ErrorKind::InvalidInput`] for a path that is not a regular file or an unreadable
//! limit setting.

use crate::{IoError, IoResultExt};
use std::fs::File;
use std::io::{self, ErrorKind, Read, Seek, SeekFrom};
use std::path::Path;

/// The most pixels (width x height) an image may have unless
/// [`MAX_IMAGE_PIXELS_ENV`] says otherwise: 50 MP, five times a Cambridge frame
/// (1920 x 1080 is 2.1 MP, a 7-Scenes frame 0.3 MP) and more than a phone photo; SIFT on
/// an image this size needs about 1 GB.
pub const MAX_IMAGE_PIXELS: u64 = 50_000_000;

/// The environment variable that sets another pixel limit (a positive whole number).
pub const MAX_IMAGE_PIXELS_ENV: &str = "PL2MAP_MAX_IMAGE_PIXELS";

/// What a file may hold beyond twice its decoded pixels: metadata (EXIF with its
/// thumbnail, ICC profiles, XMP, text chunks) and whatever a camera appends.
const METADATA_ALLOWANCE: u64 = 16 << 20;

/// How far into a JPEG its frame header (`SOFn`) is looked for: the metadata allowance.
const JPEG_HEADER_SEARCH: u64 = METADATA_ALLOWANCE;

const PNG_SIGNATURE: [u8; 8] = [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1A, b'\n'];

/// The pixel limit in force: [`MAX_IMAGE_PIXELS_ENV`] when set, [`MAX_IMAGE_PIXELS`]
/// otherwise. The variable is read once per process; a value that is not a positive
/// whole number is an error (every image is then refused, naming the variable), never
/// quietly replaced by the default.
pub fn max_image_pixels() -> io::Result<u64> {
    static LIMIT: std::sync::OnceLock<Result<u64, String>> = std::sync::OnceLock::new();
    LIMIT
        .get_or_init(|| parse_limit(std::env::var_os(MAX_IMAGE_PIXELS_ENV).as_deref()))
        .clone()
        .map_err(|m| io::Error::new(ErrorKind::InvalidInput, m))
}

/// The limit a value of [`MAX_IMAGE_PIXELS_ENV`] sets (`None`: not set).
fn parse_limit(value: Option<&std::ffi::OsStr>) -> Result<u64, String> {
    let Some(value) = value else {
        return Ok(MAX_IMAGE_PIXELS);
    };
    match value
        .to_str()
        .map(|s| s.trim().replace('_', "").parse::<u64>())
    {
        Some(Ok(n)) if n > 0 => Ok(n),
        _ => Err(format!(
            "{MAX_IMAGE_PIXELS_ENV}={}: expected a positive whole number of pixels (the \
             default is {MAX_IMAGE_PIXELS})",
            printable(value.as_encoded_bytes())
        )),
    }
}

/// What an image file's header declares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageHeader {
    /// `"PNG"` or `"JPEG"`.
    pub format: &'static str,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel as stored (a palette PNG stores one).
    pub channels: u8,
    /// 1, or 2 for 16-bit PNG and 12/16-bit JPEG samples.
    pub bytes_per_sample: u8,
}

impl ImageHeader {
    pub fn pixels(&self) -> u64 {
        self.width as u64 * self.height as u64
    }

    /// The pixels' size uncompressed, as stored.
    pub fn decoded_bytes(&self) -> u64 {
        (self.pixels()).saturating_mul(self.channels as u64 * self.bytes_per_sample as u64)
    }

    /// The longest file an image of this size is taken to be: twice its uncompressed
    /// pixels (no PNG or JPEG encoder comes near) plus 16 MiB of metadata. A longer file
    /// is not the image its header says.
    pub fn max_file_bytes(&self) -> u64 {
        self.decoded_bytes()
            .saturating_mul(2)
            .saturating_add(METADATA_ALLOWANCE)
    }

    /// Refuses an image of more than [`max_image_pixels`] pixels
    /// ([`ErrorKind::FileTooLarge`]), saying its size and the limit.
    pub fn check_limit(&self) -> io::Result<()> {
        let limit = max_image_pixels()?;
        if self.pixels() > limit {
            return Err(io::Error::new(
                ErrorKind::FileTooLarge,
                format!(
                    "the {} is too large: {}x{} is {} pixels, the limit is {limit} pixels \
                     (set {MAX_IMAGE_PIXELS_ENV} to change it)",
                    self.format,
                    self.width,
                    self.height,
                    self.pixels()
                ),
            ));
        }
        Ok(())
    }
}

/// The header of image bytes already in memory (a shard's frame), checked against the
/// pixel limit: what a decoder must ask before it allocates. A damaged or foreign header
/// is [`ErrorKind::InvalidData`], an image over the limit [`ErrorKind::FileTooLarge`].
pub fn check_bytes(bytes: &[u8]) -> io::Result<ImageHeader> {
    let header = read_header(bytes)?;
    header.check_limit()?;
    Ok(header)
}

/// Reads an image file whole, within bounds: refuses a path that is not a regular file
/// (a device such as `/dev/zero`, a FIFO, a folder) before opening it, reads the header
/// alone, refuses an image over the pixel limit, and refuses a file longer than
/// [`ImageHeader::max_file_bytes`] without reading it. The bytes are not checked beyond
/// the header: `tables::image_file::check_complete` walks the rest.
pub fn read_image(path: &Path) -> Result<Vec<u8>, IoError> {
    // Before opening: opening a FIFO for reading would wait for a writer.
    refuse_special(&std::fs::metadata(path).at(path)?).at(path)?;
    let mut file = File::open(path).at(path)?;
    // The file opened, which may not be the one looked at above.
    let meta = file.metadata().at(path)?;
    refuse_special(&meta).at(path)?;
    let header = read_header(io::BufReader::new(&file)).at(path)?;
    header.check_limit().at(path)?;
    let bound = header.max_file_bytes();
    let too_long = |len: u64| {
        io::Error::new(
            ErrorKind::InvalidData,
            format!(
                "the file is {len} bytes, more than a {}x{} {} can take (at most {bound} \
                 bytes): it is not the image its header declares",
                header.width, header.height, header.format
            ),
        )
    };
    if meta.len() > bound {
        return Err(too_long(meta.len())).at(path);
    }
    file.seek(SeekFrom::Start(0)).at(path)?;
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    // The file may grow while it is read: never past the bound.
    file.take(bound + 1).read_to_end(&mut bytes).at(path)?;
    if bytes.len() as u64 > bound {
        return Err(too_long(bytes.len() as u64)).at(path);
    }
    Ok(bytes)
}

fn refuse_special(meta: &std::fs::Metadata) -> io::Result<()> {
    let t = meta.file_type();
    if t.is_file() {
        return Ok(());
    }
    let what = if t.is_dir() {
        "a folder"
    } else {
        special_kind(&t)
    };
    Err(io::Error::new(
        ErrorKind::InvalidInput,
        format!("not a regular file but {what}: an image must be a PNG or JPEG file"),
    ))
}

#[cfg(unix)]
fn special_kind(t: &std::fs::FileType) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    if t.is_char_device() || t.is_block_device() {
        "a device"
    } else if t.is_fifo() {
        "a FIFO (named pipe)"
    } else if t.is_socket() {
        "a socket"
    } else {
        "a special file"
    }
}

#[cfg(not(unix))]
fn special_kind(_: &std::fs::FileType) -> &'static str {
    "a special file"
}

/// Reads the header of a PNG (signature and `IHDR`, 33 bytes) or JPEG (marker segments
/// up to the frame header `SOFn`) from `r`, reading nothing past it. Messages name the
/// byte offset, in the words of `tables::image_file::check_complete`.
pub fn read_header(r: impl Read) -> io::Result<ImageHeader> {
    let mut w = Walk { r, at: 0 };
    let mut head = [0u8; 8];
    let n = w.fill(&mut head)?;
    if n == 8 && head == PNG_SIGNATURE {
        return png_header(&mut w);
    }
    if n >= 2 && head[..2] == [0xFF, 0xD8] {
        // The bytes after SOI were read with the signature's 8.
        let mut w = Walk {
            r: (&head[2..n]).chain(w.r),
            at: 2,
        };
        return jpeg_header(&mut w);
    }
    Err(bad(format!(
        "neither a PNG nor a JPEG file (it starts with {:02X?})",
        &head[..n]
    )))
}

fn bad(message: String) -> io::Error {
    io::Error::new(ErrorKind::InvalidData, message)
}

/// A reader that counts the bytes it has given.
struct Walk<R> {
    r: R,
    at: u64,
}

impl<R: Read> Walk<R> {
    /// Reads until `buf` is full or the file ends; the number of bytes read.
    fn fill(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let mut got = 0;
        while got < buf.len() {
            match self.r.read(&mut buf[got..]) {
                Ok(0) => break,
                Ok(n) => got += n,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
        self.at += got as u64;
        Ok(got)
    }

    /// Fills `buf`, or says where the file ended.
    fn exact(&mut self, buf: &mut [u8], ended: impl FnOnce(u64) -> String) -> io::Result<()> {
        if self.fill(buf)? < buf.len() {
            return Err(bad(ended(self.at)));
        }
        Ok(())
    }

    /// Skips `n` bytes, or says where the file ended.
    fn skip(&mut self, n: u64, ended: impl FnOnce(u64) -> String) -> io::Result<()> {
        let got = io::copy(&mut (&mut self.r).take(n), &mut io::sink())?;
        self.at += got;
        if got < n {
            return Err(bad(ended(self.at)));
        }
        Ok(())
    }
}

fn png_header(w: &mut Walk<impl Read>) -> io::Result<ImageHeader> {
    let ended =
        |end| format!("truncated PNG: the file ends at byte {end} inside its IHDR chunk at byte 8");
    let mut chunk = [0u8; 25];
    // Length and type first: a file of zeros is named by what its first chunk is.
    w.exact(&mut chunk[..8], ended)?;
    let len = u32::from_be_bytes([chunk[0], chunk[1], chunk[2], chunk[3]]);
    let kind = &chunk[4..8];
    if kind != b"IHDR" {
        return Err(bad(format!(
            "corrupt PNG: the chunk at byte 8 is {}, not IHDR",
            printable(kind)
        )));
    }
    if len != 13 {
        return Err(bad(format!(
            "corrupt PNG: the IHDR chunk at byte 8 has length {len}, not 13"
        )));
    }
    w.exact(&mut chunk[8..], ended)?;
    let stored = u32::from_be_bytes([chunk[21], chunk[22], chunk[23], chunk[24]]);
    if crc32(&chunk[4..21]) != stored {
        return Err(bad(
            "corrupt PNG: the IHDR chunk at byte 8 fails its CRC check".into(),
        ));
    }
    let width = u32::from_be_bytes([chunk[8], chunk[9], chunk[10], chunk[11]]);
    let height = u32::from_be_bytes([chunk[12], chunk[13], chunk[14], chunk[15]]);
    let (depth, colour) = (chunk[16], chunk[17]);
    if width == 0 || height == 0 || width > i32::MAX as u32 || height > i32::MAX as u32 {
        return Err(bad(format!(
            "corrupt PNG: the IHDR chunk declares a {width}x{height} image"
        )));
    }
    let channels = match colour {
        0 | 3 => 1,
        2 => 3,
        4 => 2,
        6 => 4,
        _ => {
            return Err(bad(format!(
                "corrupt PNG: the IHDR chunk declares colour type {colour} (PNG knows 0, 2, \
                 3, 4 and 6)"
            )));
        }
    };
    Ok(ImageHeader {
        format: "PNG",
        width,
        height,
        channels,
        bytes_per_sample: if depth > 8 { 2 } else { 1 },
    })
}

/// Marker segment by marker segment from byte 2 to the first frame header.
fn jpeg_header(w: &mut Walk<impl Read>) -> io::Result<ImageHeader> {
    let truncated = |at: u64, inside: String| {
        move |end: u64| {
            format!(
                "truncated JPEG: the file ends at byte {end} inside {inside} that starts at \
                 byte {at} (no end-of-image marker)"
            )
        }
    };
    loop {
        let at = w.at;
        if at > JPEG_HEADER_SEARCH {
            return Err(bad(format!(
                "corrupt JPEG: no frame header (SOF marker) in the first {JPEG_HEADER_SEARCH} \
                 bytes"
            )));
        }
        let mut b = [0u8; 1];
        w.exact(&mut b, truncated(at, "a marker".into()))?;
        if b[0] != 0xFF {
            return Err(bad(format!(
                "corrupt JPEG: expected a marker at byte {at}, found {:02X}",
                b[0]
            )));
        }
        // Markers may be preceded by fill bytes 0xFF.
        let mut marker_at = at;
        loop {
            w.exact(&mut b, truncated(marker_at, "a marker".into()))?;
            if b[0] != 0xFF {
                break;
            }
            marker_at = w.at - 1;
        }
        let marker = b[0];
        match marker {
            // Standalone markers (TEM, RSTn): no length.
            0x01 | 0xD0..=0xD7 => continue,
            0xD9 => {
                return Err(bad(format!(
                    "corrupt JPEG: end of image at byte {marker_at} before any frame header"
                )));
            }
            0xDA => {
                return Err(bad(format!(
                    "corrupt JPEG: a scan at byte {marker_at} before any frame header (SOF \
                     marker)"
                )));
            }
            _ => {}
        }
        let inside = || format!("marker segment {marker:02X}");
        let mut len = [0u8; 2];
        w.exact(&mut len, truncated(marker_at, inside()))?;
        let len = u16::from_be_bytes(len) as u64;
        if len < 2 {
            return Err(bad(format!(
                "corrupt JPEG: marker segment {marker:02X} at byte {marker_at} has length {len}"
            )));
        }
        // SOF0..SOF15 except DHT (C4), JPG (C8) and DAC (CC).
        let is_frame = matches!(marker, 0xC0..=0xCF) && !matches!(marker, 0xC4 | 0xC8 | 0xCC);
        if !is_frame {
            w.skip(len - 2, truncated(marker_at, inside()))?;
            continue;
        }
        if len < 8 {
            return Err(bad(format!(
                "corrupt JPEG: the frame header at byte {marker_at} has length {len}, less \
                 than 8"
            )));
        }
        let mut sof = [0u8; 6];
        w.exact(&mut sof, truncated(marker_at, inside()))?;
        let precision = sof[0];
        let height = u16::from_be_bytes([sof[1], sof[2]]) as u32;
        let width = u16::from_be_bytes([sof[3], sof[4]]) as u32;
        let channels = sof[5];
        if width == 0 || height == 0 || channels == 0 {
            return Err(bad(format!(
                "corrupt JPEG: the frame header at byte {marker_at} declares a \
                 {width}x{height} image of {channels} component(s) (a height given later by \
                 a DNL marker is not supported)"
            )));
        }
        return Ok(ImageHeader {
            format: "JPEG",
            width,
            height,
            channels,
            bytes_per_sample: if precision > 8 { 2 } else { 1 },
        });
    }
}

/// CRC-32 (ISO-HDLC, as PNG uses), table-driven: the header check here and the whole-file
/// walk of `crates/tables/src/image_file.rs` (every chunk of a frame's PNG).
pub fn crc32(data: &[u8]) -> u32 {
    static TABLE: std::sync::OnceLock<[u32; 256]> = std::sync::OnceLock::new();
    let table = TABLE.get_or_init(|| {
        let mut t = [0u32; 256];
        for (n, entry) in t.iter_mut().enumerate() {
            let mut c = n as u32;
            for _ in 0..8 {
                c = if c & 1 != 0 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
            *entry = c;
        }
        t
    });
    let mut c = 0xFFFF_FFFFu32;
    for &b in data {
        c = table[((c ^ b as u32) & 0xFF) as usize] ^ (c >> 8);
    }
    c ^ 0xFFFF_FFFF
}

/// Bytes of a file (a chunk type, a decoder's message) as text that is safe in a message
/// and a log: printable characters kept, control characters and bytes that are not
/// UTF-8 escaped as `\xNN` (`\u{NNNN}` for control characters beyond ASCII). A NUL or an
/// escape sequence from a damaged file never reaches a terminal.
pub fn printable(bytes: &[u8]) -> String {
    let mut out = String::with_capacity(bytes.len());
    for chunk in bytes.utf8_chunks() {
        for c in chunk.valid().chars() {
            match c {
                c if c.is_ascii_control() => out.push_str(&format!("\\x{:02X}", c as u32)),
                c if c.is_control() => out.push_str(&format!("\\u{{{:04X}}}", c as u32)),
                c => out.push(c),
            }
        }
        for b in chunk.invalid() {
            out.push_str(&format!("\\x{b:02X}"));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    /// A folder under the system's temp folder, removed when dropped (this crate has no
    /// dependency to make one).
    struct TempDir(std::path::PathBuf);

    impl TempDir {
        fn new(name: &str) -> Self {
            let p = std::env::temp_dir().join(format!(
                "pl2map-fileio-{name}-{}-{:?}",
                std::process::id(),
                std::thread::current().id()
            ));
            let _ = std::fs::remove_dir_all(&p);
            std::fs::create_dir_all(&p).unwrap();
            TempDir(p)
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn chunk(out: &mut Vec<u8>, kind: &[u8], data: &[u8]) {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let mut body = kind.to_vec();
        body.extend_from_slice(data);
        out.extend_from_slice(&body);
        out.extend_from_slice(&crc32(&body).to_be_bytes());
    }

    /// Signature and IHDR of a `w` x `h` 8-bit grey PNG, an empty IDAT and IEND: the
    /// header is what is read; a whole image is not needed before the refusal.
    fn png_of(w: u32, h: u32) -> Vec<u8> {
        let mut png = PNG_SIGNATURE.to_vec();
        let mut ihdr = w.to_be_bytes().to_vec();
        ihdr.extend_from_slice(&h.to_be_bytes());
        ihdr.extend_from_slice(&[8, 0, 0, 0, 0]);
        chunk(&mut png, b"IHDR", &ihdr);
        chunk(&mut png, b"IDAT", &[]);
        chunk(&mut png, b"IEND", &[]);
        png
    }

    #[test]
    fn crc32_matches_the_standard_check_value() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn png_and_jpeg_headers_are_read_alone() {
        let h = check_bytes(&png_of(640, 480)).unwrap();
        assert_eq!(
            (h.format, h.width, h.height, h.channels),
            ("PNG", 640, 480, 1)
        );
        // SOI, an APP0 segment, SOF0 of 1920x1080 with 3 components; nothing after.
        let jpeg = [
            0xFF, 0xD8, 0xFF, 0xE0, 0x00, 0x04, 0xAA, 0xBB, 0xFF, 0xFF, 0xC0, 0x00, 0x11, 8, 0x04,
            0x38, 0x07, 0x80, 3,
        ];
        let h = check_bytes(&jpeg).unwrap();
        assert_eq!(
            (h.format, h.width, h.height, h.channels, h.bytes_per_sample),
            ("JPEG", 1920, 1080, 3, 1)
        );
        for cut in 2..jpeg.len() {
            let e = read_header(&jpeg[..cut]).unwrap_err();
            assert_eq!(e.kind(), ErrorKind::InvalidData);
            assert!(
                e.to_string().starts_with("truncated JPEG"),
                "cut {cut}: {e}"
            );
        }
        let e = read_header(&[0xFF, 0xD8, 0xFF, 0xDA, 0, 2][..]).unwrap_err();
        assert!(e.to_string().contains("before any frame header"), "{e}");
        let e = read_header(&b"GIF89a"[..]).unwrap_err();
        assert!(e.to_string().starts_with("neither a PNG nor a JPEG"), "{e}");
        let png = png_of(16, 12);
        for cut in 8..33 {
            let e = read_header(&png[..cut]).unwrap_err();
            assert_eq!(e.kind(), ErrorKind::InvalidData);
            assert!(e.to_string().starts_with("truncated PNG"), "cut {cut}: {e}");
        }
        let e = read_header(&png[..16]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "truncated PNG: the file ends at byte 16 inside its IHDR chunk at byte 8"
        );
        let mut flipped = png.clone();
        flipped[17] ^= 0x40;
        let e = read_header(&flipped[..]).unwrap_err();
        assert!(e.to_string().contains("CRC"), "{e}");
    }

    #[test]
    fn an_image_over_the_pixel_limit_is_refused_saying_its_size_and_the_limit() {
        let e = check_bytes(&png_of(20_000, 20_000)).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::FileTooLarge);
        assert_eq!(
            e.to_string(),
            "the PNG is too large: 20000x20000 is 400000000 pixels, the limit is 50000000 \
             pixels (set PL2MAP_MAX_IMAGE_PIXELS to change it)"
        );
        assert!(
            check_bytes(&png_of(10_000, 5_000)).is_ok(),
            "the limit itself"
        );
        assert!(check_bytes(&png_of(10_001, 5_000)).is_err());
    }

    #[test]
    fn the_limit_comes_from_the_environment_or_the_default_never_from_a_bad_value() {
        use std::ffi::OsStr;
        assert_eq!(parse_limit(None), Ok(MAX_IMAGE_PIXELS));
        assert_eq!(
            parse_limit(Some(OsStr::new("400_000_000"))),
            Ok(400_000_000)
        );
        assert_eq!(parse_limit(Some(OsStr::new(" 12 "))), Ok(12));
        for bad in ["0", "-5", "50MP", "", "1e6"] {
            let e = parse_limit(Some(OsStr::new(bad))).unwrap_err();
            assert!(e.starts_with("PL2MAP_MAX_IMAGE_PIXELS="), "{e}");
        }
        let e = parse_limit(Some(OsStr::new("\u{1b}[2J"))).unwrap_err();
        assert!(!e.contains('\u{1b}'), "{e}");
    }

    #[test]
    fn dev_zero_a_fifo_and_a_folder_are_refused_before_reading() {
        let dir = TempDir::new("special");
        let zero = Path::new("/dev/zero");
        if zero.exists() {
            let e = read_image(zero).unwrap_err();
            assert_eq!(e.kind(), ErrorKind::InvalidInput);
            assert_eq!(
                e.to_string(),
                "/dev/zero: not a regular file but a device: an image must be a PNG or \
                 JPEG file"
            );
        }
        let e = read_image(&dir.0).unwrap_err();
        assert!(
            e.to_string().contains("not a regular file but a folder"),
            "{e}"
        );
        let fifo = dir.0.join("pipe.png");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if made.is_ok_and(|s| s.success()) {
            // Opening it would wait for a writer forever: the test would hang.
            let e = read_image(&fifo).unwrap_err();
            assert!(e.to_string().contains("a FIFO"), "{e}");
        }
        let e = read_image(&dir.0.join("missing.png")).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::NotFound);
    }

    #[test]
    fn a_file_longer_than_its_header_allows_is_refused_without_reading_it() {
        let dir = TempDir::new("sparse");
        // A valid 16x12 header, then a 3 GB hole (sparse: no disk, no reading).
        let path = dir.0.join("sparse.png");
        let mut f = File::create(&path).unwrap();
        f.write_all(&png_of(16, 12)).unwrap();
        f.set_len(3 << 30).unwrap();
        drop(f);
        let e = read_image(&path).unwrap_err();
        assert_eq!(e.kind(), ErrorKind::InvalidData);
        let text = e.to_string();
        assert!(
            text.starts_with(&format!("{}: the file is 3221225472 bytes", path.display()))
                && text.contains("16x12 PNG"),
            "{text}"
        );
        // The signature alone, then the hole: the first chunk is all zeros.
        let path = dir.0.join("hole.png");
        let mut f = File::create(&path).unwrap();
        f.write_all(&PNG_SIGNATURE).unwrap();
        f.set_len(3 << 30).unwrap();
        drop(f);
        let e = read_image(&path).unwrap_err().to_string();
        assert!(
            e.ends_with("corrupt PNG: the chunk at byte 8 is \\x00\\x00\\x00\\x00, not IHDR"),
            "{e}"
        );
        assert!(!e.contains('\0'));
        // A whole small image is read as it is.
        let path = dir.0.join("small.png");
        std::fs::write(&path, png_of(16, 12)).unwrap();
        assert_eq!(read_image(&path).unwrap(), png_of(16, 12));
    }

    #[test]
    fn printable_escapes_control_characters_and_invalid_bytes() {
        assert_eq!(printable(b"IDAT"), "IDAT");
        assert_eq!(printable(b"\0\x01ab\xFF"), "\\x00\\x01ab\\xFF");
        assert_eq!(printable("é\u{9b}".as_bytes()), "é\\u{009B}");
        assert_eq!(printable(b"\x1b[2J"), "\\x1B[2J");
    }
}
