use thiserror::Error;

/// Why a Quake 3 map (loose `.bsp` or inside a `.pk3`) could not be loaded.
/// [`crate::LoadError::Bsp`] wraps it with the file name.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum BspError {
    /// Shorter than the 144-byte header.
    #[error("the file is {len} bytes, shorter than the 144-byte IBSP header; it is truncated or not a Quake 3 map")]
    Truncated {
        /// File length.
        len: usize,
    },
    /// The first four bytes are not `IBSP`.
    #[error("starts with {found:?}, not \"IBSP\"; this is not a Quake 3 BSP file (Quake 1/2, Half-Life and Source maps are not supported)")]
    BadMagic {
        /// The first four bytes.
        found: [u8; 4],
    },
    /// A BSP version other than 46.
    #[error("unsupported version {version}: only Quake 3 IBSP version 46 is supported (47 is Quake Live / RTCW, 13 is Raven's RBSP)")]
    UnsupportedVersion {
        /// The version in the header.
        version: i32,
    },
    /// A lump's offset or length lies outside the file.
    #[error("lump '{lump}' at offset {offset}, length {length} lies outside the {file_len}-byte file; the file is truncated or corrupt")]
    LumpOutOfBounds {
        /// Lump name.
        lump: &'static str,
        /// Offset from the header.
        offset: i64,
        /// Length from the header.
        length: i64,
        /// File length.
        file_len: usize,
    },
    /// A lump's length is not a whole number of records.
    #[error("lump '{lump}' is {length} bytes, not a multiple of its {record}-byte record; the file is corrupt")]
    LumpSize {
        /// Lump name.
        lump: &'static str,
        /// Its length.
        length: usize,
        /// Its record size.
        record: usize,
    },
    /// A record refers to a record of another lump that does not exist.
    #[error("{what} {record}: {field} = {value} is out of range (there are {len}); the file is corrupt")]
    IndexOutOfRange {
        /// The referring record's kind (`face`, `leaf`, `node`…).
        what: &'static str,
        /// Its index.
        record: usize,
        /// The field.
        field: &'static str,
        /// The bad value.
        value: i64,
        /// How many records the field may index.
        len: usize,
    },
    /// A record's (first, count) range does not lie inside the lump it indexes.
    #[error("{what} {record}: {field} range {first} + {count} is outside 0..{len}; the file is corrupt")]
    RangeOutOfBounds {
        /// The referring record's kind.
        what: &'static str,
        /// Its index.
        record: usize,
        /// The field.
        field: &'static str,
        /// First index.
        first: i64,
        /// Count.
        count: i64,
        /// Records available.
        len: usize,
    },
    /// A coordinate is NaN or infinite.
    #[error("{what} {record} has a NaN or infinite coordinate; the file is corrupt")]
    NonFinite {
        /// Record kind (`vertex`, `plane`).
        what: &'static str,
        /// Its index.
        record: usize,
    },
    /// A face type other than 1 to 4.
    #[error("face {face} has type {kind}; Quake 3 faces are 1 (polygon), 2 (patch), 3 (mesh) or 4 (billboard)")]
    BadFaceType {
        /// Face index.
        face: usize,
        /// Its type.
        kind: i32,
    },
    /// A polygon or mesh face whose index count is not a multiple of 3.
    #[error("face {face} has {count} mesh vertex indices, not a multiple of 3")]
    BadMeshverts {
        /// Face index.
        face: usize,
        /// Its meshvert count.
        count: i32,
    },
    /// A patch whose control grid is not odd × odd (≥ 3) or does not match its vertex count.
    #[error("patch face {face} has a {width} × {height} control grid over {vertices} vertices; both sides must be odd and ≥ 3 and their product the vertex count")]
    BadPatch {
        /// Face index.
        face: usize,
        /// Grid width.
        width: i32,
        /// Grid height.
        height: i32,
        /// Vertex count.
        vertices: i32,
    },
    /// A leaf names a cluster that does not exist.
    #[error("leaf {leaf} is in cluster {cluster}, but the visibility data has {clusters} clusters")]
    BadLeafCluster {
        /// Leaf index.
        leaf: usize,
        /// Its cluster.
        cluster: i32,
        /// Clusters in the visdata.
        clusters: usize,
    },
    /// The visdata lump is malformed.
    #[error("visdata: {message}")]
    BadVisdata {
        /// What is wrong.
        message: String,
    },
    /// The entity text is malformed.
    #[error("entities lump, byte {offset}: {message}")]
    Entities {
        /// Byte offset inside the lump.
        offset: usize,
        /// What is wrong.
        message: String,
    },
    /// A spawn point entity has a malformed `origin` or `angle`.
    #[error("entity {entity} ({classname}): {message}")]
    BadSpawn {
        /// Entity index in the entities lump.
        entity: usize,
        /// Its class.
        classname: String,
        /// What is wrong.
        message: String,
    },
    /// The geometry or the leaf references would exceed the output limit.
    #[error("the map would produce more than {limit} triangles or face references; it is corrupt or hostile (raise BspOptions::max_triangles if it is real)")]
    TooBig {
        /// The limit.
        limit: usize,
    },
    /// The file, or the pk3 entry, is bigger than the limit.
    #[error("{name} is {size} bytes, more than the {cap}-byte limit (raise BspOptions::max_bytes if it is real)")]
    TooLarge {
        /// File or entry name.
        name: String,
        /// Its (declared or read) size.
        size: u64,
        /// The limit.
        cap: u64,
    },
    /// The `.pk3` (zip) archive could not be read.
    #[error("pk3 archive: {message}")]
    Zip {
        /// The zip reader's message.
        message: String,
    },
    /// The requested map is not in the pk3.
    #[error("no map '{map}' in the pk3; it holds: {available}")]
    MapNotFound {
        /// The name asked for.
        map: String,
        /// Comma-separated map names.
        available: String,
    },
    /// The pk3 holds several maps and none was named.
    #[error("the pk3 holds several maps; name one (FILE.pk3:MAP or BspOptions::map): {available}")]
    SeveralMaps {
        /// Comma-separated map names.
        available: String,
    },
    /// The pk3 holds no `maps/*.bsp`.
    #[error("the pk3 holds no maps/*.bsp")]
    NoMaps,
    /// Every face of the world model is skipped (sky, tool shaders) or there is none.
    #[error(
        "the world model has no drawable faces (no objects): every face is sky, a tool shader, a billboard, or missing"
    )]
    NoGeometry,
    /// The generated geometry is invalid (coordinates so large that patch tessellation overflows).
    #[error("invalid geometry")]
    BadGeometry {
        /// Cause.
        source: hom::scene::SceneError,
    },
    /// The options are out of range.
    #[error("bad options: {message}")]
    BadOptions {
        /// What is wrong.
        message: String,
    },
}
