//! Maps inside `.pk3` archives (zip, deflate), read with a size limit.

use super::{le_i32, BspError, BspOptions};
use crate::LoadError;
use std::io::Read;
use std::path::Path;

/// Why [`read_capped`] failed.
pub(super) enum Capped {
    Io(std::io::Error),
    TooLarge(BspError),
}

/// Reads at most `cap` bytes; more is an error.
pub(super) fn read_capped(reader: impl Read, name: &str, cap: u64) -> Result<Vec<u8>, Capped> {
    let mut buf = Vec::new();
    reader
        .take(cap.saturating_add(1))
        .read_to_end(&mut buf)
        .map_err(Capped::Io)?;
    if buf.len() as u64 > cap {
        return Err(Capped::TooLarge(BspError::TooLarge {
            name: name.to_owned(),
            size: buf.len() as u64,
            cap,
        }));
    }
    Ok(buf)
}

fn zip_error(e: impl std::fmt::Display) -> BspError {
    BspError::Zip { message: e.to_string() }
}

/// `maps/NAME.bsp` → `NAME`.
pub(super) fn entry_map_name(entry: &str) -> String {
    let base = entry.rsplit('/').next().unwrap_or(entry);
    base.get(..base.len().saturating_sub(4)).unwrap_or(base).to_owned()
}

/// The map names (`NAME` of `maps/NAME.bsp`) in a pk3 archive, sorted.
pub fn pk3_maps(path: &Path) -> Result<Vec<String>, LoadError> {
    let label = path.display().to_string();
    let file = std::fs::File::open(path).map_err(|source| LoadError::Io {
        path: label.clone(),
        source,
    })?;
    let zip = zip::ZipArchive::new(std::io::BufReader::new(file)).map_err(|e| LoadError::Bsp {
        path: label,
        source: zip_error(e),
    })?;
    Ok(map_entries(&zip).iter().map(|e| entry_map_name(e)).collect())
}

fn map_entries<R: Read + std::io::Seek>(zip: &zip::ZipArchive<R>) -> Vec<String> {
    let mut names: Vec<String> = zip
        .file_names()
        .filter(|n| {
            let l = n.to_ascii_lowercase();
            l.starts_with("maps/") && l.ends_with(".bsp") && !l["maps/".len()..].contains('/')
        })
        .map(str::to_owned)
        .collect();
    names.sort();
    names
}

/// Reads the chosen map's bytes from a pk3 archive: (entry name, bytes).
///
/// The entry's declared size and the bytes actually inflated are both capped at
/// [`BspOptions::max_bytes`], so a zip bomb costs at most that much memory.
pub fn read_pk3<R: Read + std::io::Seek>(mut reader: R, options: &BspOptions) -> Result<(String, Vec<u8>), BspError> {
    check_central_directory(&mut reader)?;
    let mut zip = zip::ZipArchive::new(reader).map_err(zip_error)?;
    let entries = map_entries(&zip);
    let list = || entries.iter().map(|e| entry_map_name(e)).collect::<Vec<_>>().join(", ");
    let entry = match &options.map {
        Some(map) => {
            let want = format!("maps/{map}.bsp");
            entries
                .iter()
                .find(|e| e.eq_ignore_ascii_case(&want) || e.eq_ignore_ascii_case(map))
                .cloned()
                .ok_or_else(|| BspError::MapNotFound {
                    map: map.clone(),
                    available: list(),
                })?
        }
        None => match entries.len() {
            0 => return Err(BspError::NoMaps),
            1 => entries[0].clone(),
            _ => return Err(BspError::SeveralMaps { available: list() }),
        },
    };
    let file = zip.by_name(&entry).map_err(zip_error)?;
    if file.size() > options.max_bytes {
        return Err(BspError::TooLarge {
            name: entry,
            size: file.size(),
            cap: options.max_bytes,
        });
    }
    let bytes = read_capped(file, &entry, options.max_bytes).map_err(|e| match e {
        Capped::Io(e) => zip_error(format!("{entry}: {e}")),
        Capped::TooLarge(e) => e,
    })?;
    Ok((entry, bytes))
}

/// Smallest central directory record (a file header with empty name, extra and comment).
const MIN_CENTRAL_RECORD: u64 = 46;

/// Checks that the archive's entry count fits its central directory before the zip
/// reader reserves memory for that many entries: a hostile end record claiming
/// millions of entries would otherwise cost memory out of proportion to the file.
fn check_central_directory<R: Read + std::io::Seek>(reader: &mut R) -> Result<(), BspError> {
    use std::io::SeekFrom;
    let len = reader.seek(SeekFrom::End(0)).map_err(zip_error)?;
    // The end record (22 bytes) plus a comment of up to 65535 bytes.
    let tail_len = len.min(22 + 65_535);
    reader.seek(SeekFrom::Start(len - tail_len)).map_err(zip_error)?;
    let mut tail = vec![0u8; tail_len as usize];
    reader.read_exact(&mut tail).map_err(zip_error)?;
    reader.seek(SeekFrom::Start(0)).map_err(zip_error)?;
    let Some(eocd) = (0..tail.len().saturating_sub(21))
        .rev()
        .find(|&i| tail[i..i + 4] == *b"PK\x05\x06")
    else {
        // No end record: the zip reader reports it.
        return Ok(());
    };
    let u16_at = |b: &[u8], i: usize| u64::from(u16::from_le_bytes([b[i], b[i + 1]]));
    let u32_at = |b: &[u8], i: usize| u64::from(le_i32(b, i) as u32);
    let mut entries = u16_at(&tail, eocd + 10);
    let mut size = u32_at(&tail, eocd + 12);
    if entries == 0xffff || size == 0xffff_ffff {
        // Zip64: the locator just before the end record points at the zip64 end record.
        if eocd >= 20 && tail[eocd - 20..eocd - 16] == *b"PK\x06\x07" {
            let at = u32_at(&tail, eocd - 12) | (u32_at(&tail, eocd - 8) << 32);
            if at.checked_add(56).is_none_or(|end| end > len) {
                return Err(zip_error("the zip64 end record lies outside the file"));
            }
            let mut record = [0u8; 56];
            reader.seek(SeekFrom::Start(at)).map_err(zip_error)?;
            reader.read_exact(&mut record).map_err(zip_error)?;
            reader.seek(SeekFrom::Start(0)).map_err(zip_error)?;
            if record[..4] == *b"PK\x06\x06" {
                let u64_at = |i: usize| u32_at(&record, i) | (u32_at(&record, i + 4) << 32);
                entries = u64_at(32);
                size = u64_at(40);
            }
        }
    }
    if size > len || entries.saturating_mul(MIN_CENTRAL_RECORD) > size {
        return Err(zip_error(format!(
            "the central directory claims {entries} entries in {size} bytes of a {len}-byte file; the archive is corrupt"
        )));
    }
    Ok(())
}
