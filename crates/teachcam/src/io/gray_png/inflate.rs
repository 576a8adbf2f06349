//! Inflating a frame file's zlib stream up to four literals per table look-up.
//!
//! A frame's filtered rows are mostly small numbers (the difference of neighbouring noisy
//! pixels), so most Huffman codes of its stream are 2 to 5 bits long and one 12-bit look-up
//! covers up to four of them. General decoders (fdeflate, zlib, libdeflate) decode one or two
//! literals a look-up; the look-ups form one chain (each starts where the last one's codes
//! end), so the literals a look-up yields set the speed: 1.6–2.0 times fdeflate on the
//! simulator's frames (notes/speed.md).
//!
//! zlib and libpng (OpenCV, PIL) start a new block every 16 K symbols, about 80 a frame, each
//! with codes of its own, so the tables are rebuilt for every block, in the memory of the
//! stream's first: the codes' tables by doubling (as libdeflate does), each run from the
//! run already built for the bits after its first literal.
//!
//! It takes every zlib stream (RFC 1950) of deflate blocks (RFC 1951) of any kind: stored,
//! fixed and dynamic Huffman codes, codes up to 15 bits (those longer than 12 bits, rare by
//! construction, are decoded a bit at a time), as PNG writers make them (fdeflate, zlib and
//! libpng at levels 0–9, OpenCV, PIL, FFmpeg). It returns `None` for a preset dictionary, a
//! code set zlib would refuse (over-subscribed, or incomplete but for a single distance code),
//! a stream that is cut, corrupt, too long or too short for the rows; the caller then inflates
//! with the general decoder, which gives its own verdict. What it returns is RFC 1951's one
//! output for the stream.

/// Bits a table look-up reads.
const TABLE_BITS: u32 = 12;
/// Entries of a look-up table.
const TABLE_SIZE: usize = 1 << TABLE_BITS;
/// The mask of a look-up's bits.
const TABLE_MASK: u64 = (1 << TABLE_BITS) - 1;
/// Literals at most in one look-up (four bytes are written at a time).
const RUN_MAX: u32 = 4;
/// Bits a refill leaves in the buffer at least ([`Bits::refill`]).
const REFILL_BITS: u32 = 56;
/// Run look-ups at most between two refills: six of 9 bits.
const LOOKUPS_MAX: usize = 6;

/// Length symbols 257–285: base length and extra bits (RFC 1951 §3.2.5).
const LENGTH_BASE: [u16; 29] = [
    3, 4, 5, 6, 7, 8, 9, 10, 11, 13, 15, 17, 19, 23, 27, 31, 35, 43, 51, 59, 67, 83, 99, 115, 131,
    163, 195, 227, 258,
];
const LENGTH_EXTRA: [u8; 29] = [
    0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0,
];
/// Distance symbols 0–29: base distance and extra bits (RFC 1951 §3.2.5).
const DISTANCE_BASE: [u16; 30] = [
    1, 2, 3, 4, 5, 7, 9, 13, 17, 25, 33, 49, 65, 97, 129, 193, 257, 385, 513, 769, 1025, 1537,
    2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577,
];
const DISTANCE_EXTRA: [u8; 30] = [
    0, 0, 0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5, 6, 6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13,
    13,
];
/// The order a dynamic block stores the code length code's lengths in (RFC 1951 §3.2.7).
const CODE_LENGTH_ORDER: [usize; 19] = [
    16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15,
];
/// Literal/length symbols (286, 287 never occur) and distance symbols a block may declare.
const LITLEN_SYMBOLS: usize = 286;
const DISTANCE_SYMBOLS: usize = 30;
/// The end-of-block symbol.
const END_OF_BLOCK: u16 = 256;

/// A code's look-up table on the stream's next 12 bits: `symbol << 4 | code length` where a
/// code of at most 12 bits starts, 0 where none does (a longer code, or none at all: an
/// incomplete distance code).
type SymbolTable = [u16; TABLE_SIZE];

/// Longest code deflate allows (RFC 1951 §3.2.7).
const MAX_CODE_BITS: usize = 15;

/// How a code set may fall short of complete.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Completeness {
    /// Every bit pattern starts a code (literal/length and code length codes).
    Complete,
    /// As zlib allows for distances: complete, no code at all, or a single code.
    SingleAllowed,
}

/// A canonical Huffman code (RFC 1951 §3.2.2): the table of its codes of up to 12 bits, and
/// what decoding its longer codes a bit at a time needs. Built anew for each block in the
/// same memory (a stream's blocks share one set of tables).
struct Code {
    table: Box<SymbolTable>,
    /// The mask of the bits `table` is built for: its longest code's (at most 12), or more
    /// when asked ([`Code::build`]); the entries past them are stale.
    mask: usize,
    /// Codes of each length.
    count: [u16; MAX_CODE_BITS + 1],
    /// The symbols in the order of their codes (by length, then symbol).
    sorted: [u16; LITLEN_CODES],
}

/// Symbols a code may have at most (the fixed literal/length code's 288).
const LITLEN_CODES: usize = 288;

impl Code {
    fn empty() -> Self {
        Self {
            table: Box::new([0; TABLE_SIZE]),
            mask: 0,
            count: [0; MAX_CODE_BITS + 1],
            sorted: [0; LITLEN_CODES],
        }
    }

    /// Makes this the code of `lengths` (at most 288); `None` when the set is
    /// over-subscribed, or incomplete beyond what `completeness` allows.
    ///
    /// The table grows by doubling, as libdeflate builds its tables: at length `n` it has
    /// 2^n entries, each code of `n` bits is written once at its (bit-reversed) index, and
    /// going to `n + 1` bits copies the table after itself. A code's entry then repeats
    /// under every pattern of the bits after it, for about 4096 copied entries in all
    /// instead of one loop a symbol over its table stride. The doubling stops at the longest
    /// code (or at 12 bits), but not before `least_bits`: a distance code of zlib's `Z_RLE`
    /// blocks has one code, the code length code at most 7 bits, and 80 blocks a frame
    /// built each to 4096 entries copied more than the frame's size.
    fn build(&mut self, lengths: &[u8], completeness: Completeness, least_bits: u32) -> Option<()> {
        let mut count = [0u16; MAX_CODE_BITS + 1];
        for &length in lengths {
            *count.get_mut(usize::from(length))? += 1;
        }
        count[0] = 0;
        // `unused` counts the bit patterns of each length left by the shorter codes.
        let mut unused = 1i32;
        for &codes in &count[1..] {
            unused = (unused << 1) - i32::from(codes);
            if unused < 0 {
                return None;
            }
        }
        let codes: u16 = count.iter().sum();
        let allowed = unused == 0 || (completeness == Completeness::SingleAllowed && codes <= 1);
        if !allowed {
            return None;
        }
        // Counting sort: each length's symbols start after the shorter lengths' ones.
        let mut offset = [0usize; MAX_CODE_BITS + 2];
        for length in 1..=MAX_CODE_BITS {
            offset[length + 1] = offset[length] + usize::from(count[length]);
        }
        for (symbol, &length) in lengths.iter().enumerate() {
            if length != 0 {
                let slot = &mut offset[usize::from(length)];
                *self.sorted.get_mut(*slot)? = u16::try_from(symbol).ok()?;
                *slot += 1;
            }
        }
        let longest = (1..=MAX_CODE_BITS)
            .rev()
            .find(|&n| count[n] > 0)
            .unwrap_or(0);
        let top = (longest as u32).clamp(least_bits.max(1), TABLE_BITS);
        let table = &mut self.table;
        table[0] = 0;
        let (mut size, mut code, mut next) = (1usize, 0u32, 0usize);
        for bits in 1..=top {
            table.copy_within(0..size, size);
            size <<= 1;
            for &symbol in &self.sorted[next..next + usize::from(count[bits as usize])] {
                // A code's first bit comes first in the stream: the index holds the code
                // reversed.
                let reversed = (code.reverse_bits() >> (32 - bits)) as usize;
                table[reversed] = symbol << 4 | bits as u16;
                code += 1;
            }
            next += usize::from(count[bits as usize]);
            code <<= 1;
        }
        self.count = count;
        self.mask = size - 1;
        Some(())
    }

    /// Whether some code is longer than the table's 12 bits.
    #[cfg(test)]
    fn has_long_codes(&self) -> bool {
        self.count[TABLE_BITS as usize + 1..].iter().any(|&c| c > 0)
    }

    /// The next symbol of the stream and its code's length (the caller refilled: at least
    /// 15 bits), without consuming it; `None` where no code starts.
    #[inline(always)]
    fn peek(&self, bits: &Bits<'_>) -> Option<(usize, u32)> {
        let entry = self.table[bits.index() & self.mask];
        if entry != 0 {
            return Some((usize::from(entry >> 4), u32::from(entry & 15)));
        }
        self.peek_long(bits.buffer)
    }

    /// A code longer than 12 bits, a bit at a time (as zlib's `puff` does).
    #[cold]
    fn peek_long(&self, buffer: u64) -> Option<(usize, u32)> {
        let (mut code, mut first, mut index) = (0usize, 0usize, 0usize);
        for length in 1..=MAX_CODE_BITS {
            code |= ((buffer >> (length - 1)) & 1) as usize;
            let count = usize::from(self.count[length]);
            if code < first + count {
                let symbol = *self.sorted.get(index + code - first)?;
                return Some((usize::from(symbol), length as u32));
            }
            index += count;
            first = (first + count) << 1;
            code <<= 1;
        }
        None
    }
}

/// The literal runs of a literal/length code: for each index of `bits` bits (12, or 9 for
/// short blocks: [`run_bits_after`]), the literals whose codes lie whole in it, up to four.
struct LiteralRuns {
    /// An index's run: the bits the literals take in the low six bits, how many less one in
    /// the high two; 0 where the index starts with a length or end-of-block code, or a literal
    /// code longer than the index: no run. Each look-up's index waits on the last one's
    /// `meta`, so it is kept small (4 KiB stay in the core's first cache beside the rest) and
    /// the buffer shifts by it unmasked (a shift takes its count's low six bits).
    meta: Box<[u8; TABLE_SIZE]>,
    /// An index's literals, the first lowest.
    bytes: Box<[u32; TABLE_SIZE]>,
    /// Where the first three literals' codes end in the index, a byte each, the first
    /// lowest; [`NO_END`] past the run (used while building).
    ends: Box<[u32; TABLE_SIZE]>,
    /// The bits of an index, and their mask.
    index_bits: u32,
    mask: u64,
    /// Look-ups the buffer holds after a refill: `REFILL_BITS` / the index's bits.
    per_refill: usize,
}

/// The end of a literal a run does not have: more than any room, and below a byte's high bit.
const NO_END: u32 = 0x7f;

impl LiteralRuns {
    fn empty() -> Self {
        Self {
            meta: Box::new([0; TABLE_SIZE]),
            bytes: Box::new([0; TABLE_SIZE]),
            ends: Box::new([0; TABLE_SIZE]),
            index_bits: TABLE_BITS,
            mask: TABLE_MASK,
            per_refill: 0,
        }
    }

    /// The index of the stream's next bits.
    #[inline(always)]
    fn index(&self, bits: &Bits<'_>) -> usize {
        // (The mask is at most 12 bits; the second one lets the compiler see the bound.)
        (bits.buffer & self.mask) as usize & (TABLE_SIZE - 1)
    }

    /// [`LiteralRuns::index`] for a table of `INDEX_BITS` bits (0: any).
    #[inline(always)]
    fn index_by<const INDEX_BITS: u32>(&self, bits: &Bits<'_>) -> usize {
        if INDEX_BITS == 0 {
            self.index(bits)
        } else {
            (bits.buffer & ((1 << INDEX_BITS) - 1)) as usize
        }
    }

    /// Makes these the runs of the code whose table is `single`, on indices of `index_bits`.
    ///
    /// An index's run is its first literal followed by the run of the bits after that
    /// literal's code, cut to the literals whose codes end within the index: that later
    /// index is smaller, so its run is already built (index 0, whose later index is itself,
    /// is decoded whole). Without branches (which literal ends a run is as good as random,
    /// and a mispredicted branch an index would cost more than the rest of its building):
    /// the ends that fit are counted a byte lane each.
    fn build(&mut self, single: &SymbolTable, index_bits: u32) {
        self.index_bits = index_bits;
        self.mask = (1 << index_bits) - 1;
        self.per_refill = ((REFILL_BITS / index_bits) as usize).min(LOOKUPS_MAX);
        let (ends, bytes) = Self::decode_whole(single, 0, index_bits);
        (self.meta[0], self.bytes[0], self.ends[0]) = Self::run(single[0], index_bits, ends, bytes);
        let size = 1usize << index_bits;
        for (index, &entry) in single.iter().enumerate().take(size).skip(1) {
            // (A length of 0, no code, takes the whole index: `rest` is 0.)
            let length = u32::from(entry & 15).max(1).min(index_bits);
            let rest = index >> length;
            let (rest_ends, rest_bytes) = (self.ends[rest], self.bytes[rest]);
            (self.meta[index], self.bytes[index], self.ends[index]) =
                Self::run(entry, index_bits, rest_ends, rest_bytes);
        }
    }

    /// An index's `meta`, literals and ends, from its `single` entry and the run after its
    /// first code (its ends and literals).
    #[inline(always)]
    fn run(entry: u16, index_bits: u32, rest_ends: u32, rest_bytes: u32) -> (u8, u32, u32) {
        const LANES: u32 = 0x01_01_01;
        let (symbol, length) = (u32::from(entry >> 4), u32::from(entry & 15));
        // Not a literal whose code fits: no run (computed on as if one was).
        let literal = length != 0 && symbol < 256 && length <= index_bits;
        let length = if literal { length } else { index_bits };
        // The later literals whose codes end within the bits this index has left: a
        // lane's high bit stays set where `room - end` is not negative. The ends
        // increase, so the lanes that fit are the lowest; their count is the sum of the
        // lanes' bits, which the multiplication gathers in the third lane.
        let room = index_bits - length;
        let high = 0x80 * LANES;
        let fits = (((room * LANES) | high) - (rest_ends & 0xff_ff_ff)) & high;
        let taken = (((fits >> 7) * LANES) >> 16) & 3;
        let kept = (1u32 << (8 * taken)) - 1;
        let later = ((rest_ends + length * LANES) & kept) | ((NO_END * LANES) & !kept);
        let ends = length | later << 8;
        let bits = (ends >> (8 * taken)) & 0xff;
        let bytes = symbol | ((u64::from(rest_bytes) << 8) & ((1 << (8 * taken + 8)) - 1)) as u32;
        if literal {
            ((taken << 6 | bits) as u8, bytes, ends)
        } else {
            (0, bytes, NO_END * LANES)
        }
    }

    /// The run of `index` decoded a literal at a time: its literals' ends (as
    /// [`LiteralRuns::ends`] holds them) and the literals.
    fn decode_whole(single: &SymbolTable, index: usize, index_bits: u32) -> (u32, u32) {
        let (mut bits, mut count, mut bytes, mut ends) = (0u32, 0u32, 0u32, NO_END * 0x01_01_01);
        while count < RUN_MAX {
            // The bits past the index's read as zeros: a code counts only if whole.
            let entry = single[index >> bits];
            let (symbol, length) = (u32::from(entry >> 4), u32::from(entry & 15));
            if length == 0 || symbol >= 256 || bits + length > index_bits {
                break;
            }
            bytes |= symbol << (8 * count);
            bits += length;
            if count < 3 {
                ends = ends & !(0xff << (8 * count)) | bits << (8 * count);
            }
            count += 1;
        }
        (ends, bytes)
    }
}

/// Building a run table costs about 25 cycles an entry (measured: 12-bit tables for each of
/// the 80 blocks of an OpenCV-written frame made its inflate 2.7 times slower than 10-bit
/// ones), while decoding zlib's 16 K symbols a block (libpng, OpenCV) takes a few cycles a
/// literal. After a block of fewer than this many bytes the next block's table has 9 bits
/// (an eighth of the entries, two or three short literals an index instead of three or four;
/// 10% faster than 10 bits and than 8 on OpenCV's frames); fdeflate's one block a frame
/// keeps 12.
const LONG_BLOCK_BYTES: usize = 1 << 18;

/// The run table's bits for the block after one that wrote `block_bytes`.
fn run_bits_after(block_bytes: usize) -> u32 {
    if block_bytes < LONG_BLOCK_BYTES {
        9
    } else {
        TABLE_BITS
    }
}

/// The stream's bits, least significant first, loaded eight bytes at a time.
#[derive(Clone, Copy)]
struct Bits<'a> {
    input: &'a [u8],
    /// The next byte of `input` to load (past its end: zeros were loaded).
    next: usize,
    buffer: u64,
    /// Valid bits in `buffer`.
    count: u32,
}

impl Bits<'_> {
    /// At least 56 bits in the buffer (zeros past the input's end: [`Bits::bytes_read`]
    /// tells whether any was consumed).
    #[inline(always)]
    fn refill(&mut self) {
        if let Some(eight) = self.input.get(self.next..self.next + 8) {
            let mut word = [0u8; 8];
            word.copy_from_slice(eight);
            self.buffer |= u64::from_le_bytes(word) << self.count;
            self.next += ((63 - self.count) / 8) as usize;
            self.count |= 56;
        } else {
            while self.count <= 56 {
                let byte = self.input.get(self.next).copied().unwrap_or(0);
                self.buffer |= u64::from(byte) << self.count;
                self.next += 1;
                self.count += 8;
            }
        }
    }

    /// The next 12 bits, a table index.
    #[inline(always)]
    fn index(&self) -> usize {
        (self.buffer & TABLE_MASK) as usize
    }

    #[inline(always)]
    fn consume(&mut self, bits: u32) {
        self.buffer >>= bits;
        self.count -= bits;
    }

    /// Drops as many bits of the buffer as `value`'s low six bits say, leaving `count` to the
    /// caller. The shift takes `value` itself (a 64-bit shift uses its count's low six bits):
    /// the next look-up's index does not wait on a mask.
    #[inline(always)]
    fn shift_buffer(&mut self, value: u32) {
        self.buffer = self.buffer.wrapping_shr(value);
    }

    /// The next `bits` bits as a number (at most 13 here; the caller refilled).
    #[inline(always)]
    fn take(&mut self, bits: u32) -> usize {
        let value = (self.buffer & ((1 << bits) - 1)) as usize;
        self.consume(bits);
        value
    }

    /// Whole bytes of the input read so far (a partly read byte counts); `None` when bits
    /// past the input's end were read: the stream is cut.
    fn bytes_read(&self) -> Option<usize> {
        let bits = self.next * 8 - self.count as usize;
        let bytes = bits.div_ceil(8);
        (bytes <= self.input.len()).then_some(bytes)
    }
}

/// Inflates the zlib stream `stream` into `out`, which it must fill exactly, and after which
/// only its Adler-32 may follow (not checked: the PNG chunks' CRC-32 covers the same bytes).
/// `None` for a stream this decoder does not take or that is not valid (module doc).
///
/// `progress` is shown what is inflated so far (`out`'s start) each time about `piece` more
/// bytes are, and at the end: the caller uses them while they are in the core's cache. It
/// may have seen part of a stream that turns out `None`.
pub(super) fn inflate_zlib(
    stream: &[u8],
    out: &mut [u8],
    piece: usize,
    mut progress: impl FnMut(&[u8]),
) -> Option<()> {
    Lane::new(stream, out, piece, &mut progress)?.inflate_alone()
}

/// Inflates two zlib streams, each as [`inflate_zlib`] inflates it (its own output, pieces
/// and progress; each verdict its own), the literal runs of both decoded in one loop.
///
/// A stream's run look-ups form one chain (each index is the bits the last run left), so one
/// stream keeps the core waiting on each look-up's load; a second, independent chain fills
/// those waits (notes/speed.md). Once one stream ends or fails, the other goes on alone.
pub(super) fn inflate_zlib_pair(
    streams: [&[u8]; 2],
    outs: [&mut [u8]; 2],
    pieces: [usize; 2],
    progress: [Progress<'_>; 2],
) -> [Option<()>; 2] {
    let [out_a, out_b] = outs;
    let [progress_a, progress_b] = progress;
    let a = Lane::new(streams[0], out_a, pieces[0], progress_a);
    let b = Lane::new(streams[1], out_b, pieces[1], progress_b);
    match (a, b) {
        (Some(a), Some(b)) => inflate_together(a, b),
        (a, b) => [
            a.and_then(Lane::inflate_alone),
            b.and_then(Lane::inflate_alone),
        ],
    }
}

/// [`inflate_zlib_pair`] once both streams' headers are read.
fn inflate_together(mut a: Lane<'_, '_, '_>, mut b: Lane<'_, '_, '_>) -> [Option<()>; 2] {
    loop {
        match (a.enter_block(), b.enter_block()) {
            (Some(true), Some(true)) => {}
            (ready_a, ready_b) => return [a.go_on_alone(ready_a), b.go_on_alone(ready_b)],
        }
        // The look-ups a refill holds and the index's bits as constants where the two tables
        // agree (a mask in a register less: the loop's state then fits in the registers).
        let [next_a, next_b] = match (a.tables.runs.index_bits, b.tables.runs.index_bits) {
            (9, 9) => runs_together::<LOOKUPS_MAX, 9>(&mut a, &mut b),
            (12, 12) => runs_together::<4, 12>(&mut a, &mut b),
            _ => runs_together::<4, 0>(&mut a, &mut b),
        };
        if a.go_on(next_a).is_none() {
            return [None, b.inflate_alone()];
        }
        if b.go_on(next_b).is_none() {
            return [a.inflate_alone(), None];
        }
    }
}

/// Where a stream stands when [`runs_together`] returns.
#[derive(Clone, Copy)]
enum Next {
    /// Inside its block.
    InBlock,
    /// Its block ended.
    EndOfBlock,
    /// It is not valid.
    Invalid,
}

/// Two streams' Huffman blocks decoded side by side, as [`inflate_block_by`] decodes one
/// stream's, until either block ends, either stream turns out invalid, or either nears the
/// end of its output or its next report.
///
/// `INDEX_BITS` is both tables' index bits, or 0 when they differ; `PER_REFILL` look-ups of
/// the longer index fit in a refill.
#[inline(never)]
fn runs_together<const PER_REFILL: usize, const INDEX_BITS: u32>(
    a: &mut Lane<'_, '_, '_>,
    b: &mut Lane<'_, '_, '_>,
) -> [Next; 2] {
    let window = 4 * PER_REFILL + 1;
    // Copies of the streams' states, which the compiler keeps in registers.
    let (mut bits_a, mut bits_b) = (a.bits, b.bits);
    let (mut written_a, mut written_b) = (a.written, b.written);
    let (tables_a, tables_b) = (&a.tables, &b.tables);
    let (runs_a, runs_b) = (&tables_a.runs, &tables_b.runs);
    let (out_a, out_b) = (&mut *a.out, &mut *b.out);
    // Each stream goes on while its window fits in its output, up to its next report.
    let end_a = a.report.next.min((out_a.len() + 1).saturating_sub(window));
    let end_b = b.report.next.min((out_b.len() + 1).saturating_sub(window));
    let mut next = [Next::InBlock; 2];
    while written_a < end_a && written_b < end_b {
        bits_a.refill();
        bits_b.refill();
        let (Some(window_a), Some(window_b)) = (
            out_a.get_mut(written_a..written_a + window),
            out_b.get_mut(written_b..written_b + window),
        ) else {
            break;
        };
        // As in `inflate_block_by`: the metas summed, the buffers shifted by them unmasked;
        // both streams stop at the first look-up that is not a run in either.
        let (mut lookups, mut taken_a, mut taken_b) = (0, 0u32, 0u32);
        while lookups < PER_REFILL {
            let index_a = runs_a.index_by::<INDEX_BITS>(&bits_a);
            let index_b = runs_b.index_by::<INDEX_BITS>(&bits_b);
            let meta_a = u32::from(runs_a.meta[index_a]);
            let meta_b = u32::from(runs_b.meta[index_b]);
            if meta_a == 0 || meta_b == 0 {
                break;
            }
            let at_a = (taken_a >> 6) as usize + lookups;
            window_a[at_a..at_a + 4].copy_from_slice(&runs_a.bytes[index_a].to_le_bytes());
            let at_b = (taken_b >> 6) as usize + lookups;
            window_b[at_b..at_b + 4].copy_from_slice(&runs_b.bytes[index_b].to_le_bytes());
            bits_a.shift_buffer(meta_a);
            bits_b.shift_buffer(meta_b);
            taken_a += meta_a;
            taken_b += meta_b;
            lookups += 1;
        }
        bits_a.count -= taken_a & 63;
        bits_b.count -= taken_b & 63;
        written_a += (taken_a >> 6) as usize + lookups;
        written_b += (taken_b >> 6) as usize + lookups;
        if lookups == PER_REFILL {
            continue;
        }
        // A stream whose next symbol is not a run: that symbol, here (one in 50 look-ups on
        // OpenCV's frames: leaving the loop for it cost more than the symbol).
        // (The loop's condition checks the windows again.)
        (written_a, next[0]) = symbol_unless_run(&mut bits_a, tables_a, out_a, written_a, true);
        (written_b, next[1]) = symbol_unless_run(&mut bits_b, tables_b, out_b, written_b, true);
        if !matches!(next, [Next::InBlock, Next::InBlock]) {
            break;
        }
    }
    (a.bits, a.written) = (bits_a, written_a);
    (b.bits, b.written) = (bits_b, written_b);
    next
}

/// A stream's next symbol by [`symbol`] unless a literal run comes next and `room` says its
/// window fits in `out`; how far `out` is written after it, and where the stream stands.
#[inline(always)]
fn symbol_unless_run(
    bits: &mut Bits<'_>,
    tables: &Tables,
    out: &mut [u8],
    written: usize,
    room: bool,
) -> (usize, Next) {
    bits.refill();
    if room && tables.runs.meta[tables.runs.index(bits)] != 0 {
        return (written, Next::InBlock);
    }
    match symbol(bits, tables, out, written) {
        Some(Symbol::Wrote(after)) => (after, Next::InBlock),
        Some(Symbol::EndOfBlock) => (written, Next::EndOfBlock),
        None => (written, Next::Invalid),
    }
}

/// One zlib stream being inflated, taken on a block or a symbol at a time: between blocks, or
/// inside a Huffman block's data.
struct Lane<'s, 'o, 'p> {
    bits: Bits<'s>,
    out: &'o mut [u8],
    /// Bytes of `out` written.
    written: usize,
    tables: Tables,
    /// The bits of the next Huffman block's run table ([`run_bits_after`]).
    run_bits: u32,
    /// Where the Huffman block being inflated started in `out`; `None` between blocks.
    block_start: Option<usize>,
    /// Whether the block read last is the stream's last.
    last: bool,
    report: Report<'p>,
}

impl<'s, 'o, 'p> Lane<'s, 'o, 'p> {
    /// A stream whose zlib header is read; `None` when this decoder does not take it.
    fn new(
        stream: &'s [u8],
        out: &'o mut [u8],
        piece: usize,
        progress: Progress<'p>,
    ) -> Option<Self> {
        let (&[method, flags], body) = stream.split_first_chunk::<2>()?;
        // Deflate, a window of at most 32 KiB, the header's check, no preset dictionary
        // (RFC 1950 §2.2).
        let header = u16::from_be_bytes([method, flags]);
        if method & 15 != 8 || method >> 4 > 7 || header % 31 != 0 || flags & 0x20 != 0 {
            return None;
        }
        Some(Self {
            bits: Bits {
                input: body,
                next: 0,
                buffer: 0,
                count: 0,
            },
            out,
            written: 0,
            tables: Tables::empty(),
            run_bits: TABLE_BITS,
            block_start: None,
            last: false,
            // (At least a byte a piece: a stream paired with another advances between
            // reports.)
            report: Report {
                piece: piece.max(1),
                next: piece.max(1),
                progress,
            },
        })
    }

    /// The rest of the stream, one Huffman block at a time by [`inflate_block`].
    fn inflate_alone(mut self) -> Option<()> {
        while self.enter_block()? {
            self.written = inflate_block(
                &mut self.bits,
                &self.tables,
                self.out,
                self.written,
                &mut self.report,
            )?;
            self.end_block();
        }
        self.finish()
    }

    /// After [`Lane::enter_block`] said `ready`: the stream inflated to its end alone.
    fn go_on_alone(self, ready: Option<bool>) -> Option<()> {
        match ready? {
            true => self.inflate_alone(),
            false => self.finish(),
        }
    }

    /// Reads block headers (copying stored blocks) until a Huffman block's data comes next,
    /// its tables built: `Some(true)`; `Some(false)` once the last block is done; `None`
    /// for a stream that is not valid. Inside a Huffman block it does nothing.
    fn enter_block(&mut self) -> Option<bool> {
        while self.block_start.is_none() {
            if self.last {
                return Some(false);
            }
            self.bits.refill();
            self.last = self.bits.take(1) == 1;
            match self.bits.take(2) {
                0 => {
                    self.written = copy_stored(&mut self.bits, self.out, self.written)?;
                    self.report.check(&self.out[..self.written]);
                }
                1 => {
                    self.tables.build_fixed(self.run_bits)?;
                    self.block_start = Some(self.written);
                }
                2 => {
                    self.tables.read_dynamic(&mut self.bits, self.run_bits)?;
                    self.block_start = Some(self.written);
                }
                _ => return None, // block type 3 is reserved
            }
        }
        Some(true)
    }

    /// After a Huffman block's end.
    fn end_block(&mut self) {
        if let Some(start) = self.block_start.take() {
            self.run_bits = run_bits_after(self.written - start);
        }
        self.report.check(&self.out[..self.written]);
    }

    /// Takes the stream on from where [`runs_together`] left it (`next`): its block ended,
    /// or the progress shown when due and the next symbol decoded by [`symbol`] unless a
    /// literal run with room for it comes next. `None` for a stream that is not valid.
    fn go_on(&mut self, next: Next) -> Option<()> {
        let next = match next {
            Next::InBlock => {
                self.report.check(&self.out[..self.written]);
                let room = self.written + 4 * self.tables.runs.per_refill < self.out.len();
                let (written, next) =
                    symbol_unless_run(&mut self.bits, &self.tables, self.out, self.written, room);
                self.written = written;
                next
            }
            ended_or_invalid => ended_or_invalid,
        };
        match next {
            Next::InBlock => {}
            Next::EndOfBlock => self.end_block(),
            Next::Invalid => return None,
        }
        Some(())
    }

    /// The stream's end: the whole output shown, its length and the input's checked.
    fn finish(self) -> Option<()> {
        (self.report.progress)(&self.out[..self.written]);
        let read = self.bits.bytes_read()?;
        (self.written == self.out.len() && read.checked_add(4)? == self.bits.input.len())
            .then_some(())
    }
}

/// Copies a stored block (RFC 1951 §3.2.4; its 3 header bits read) into `out` from `written`
/// on; how far `out` is written after it.
fn copy_stored(bits: &mut Bits<'_>, out: &mut [u8], written: usize) -> Option<usize> {
    // To the next byte boundary; the buffer's whole bytes are the ones before `next`.
    bits.consume(bits.count % 8);
    let at = bits.next.checked_sub((bits.count / 8) as usize)?;
    let header = bits.input.get(at..at.checked_add(4)?)?;
    let length = usize::from(u16::from_le_bytes([header[0], header[1]]));
    let check = u16::from_le_bytes([header[2], header[3]]);
    if usize::from(!check) != length {
        return None;
    }
    let start = at + 4;
    let data = bits.input.get(start..start + length)?;
    let end = written.checked_add(length)?;
    out.get_mut(written..end)?.copy_from_slice(data);
    bits.next = start + length;
    bits.buffer = 0;
    bits.count = 0;
    Some(end)
}

/// What is shown the output inflated so far.
type Progress<'p> = &'p mut dyn FnMut(&[u8]);

/// Where the caller is next shown the output.
struct Report<'p> {
    piece: usize,
    /// The output's length at which `progress` is called next.
    next: usize,
    progress: Progress<'p>,
}

impl Report<'_> {
    /// Shows `done` (the output so far) when it reached the next piece.
    #[inline(always)]
    fn check(&mut self, done: &[u8]) {
        if done.len() >= self.next {
            (self.progress)(done);
            self.next = done.len().saturating_add(self.piece);
        }
    }
}

/// A Huffman block's tables, built anew for each block in the memory of the stream's first.
struct Tables {
    runs: LiteralRuns,
    litlen: Code,
    distance: Code,
    /// A dynamic block header's code length code.
    code_lengths: Code,
}

impl Tables {
    fn empty() -> Self {
        Self {
            runs: LiteralRuns::empty(),
            litlen: Code::empty(),
            distance: Code::empty(),
            code_lengths: Code::empty(),
        }
    }

    fn build(
        &mut self,
        litlen_lengths: &[u8],
        distance_lengths: &[u8],
        run_bits: u32,
    ) -> Option<()> {
        // The runs are built from the whole literal/length table.
        self.litlen
            .build(litlen_lengths, Completeness::Complete, TABLE_BITS)?;
        self.distance
            .build(distance_lengths, Completeness::SingleAllowed, 1)?;
        self.runs.build(&self.litlen.table, run_bits);
        Some(())
    }

    /// The fixed codes (RFC 1951 §3.2.6): literal/length symbols 0–143 of 8 bits, 144–255 of
    /// 9, 256–279 of 7, 280–287 of 8 (286 and 287 never valid), and 32 distance codes of 5
    /// bits (30 and 31 never valid).
    fn build_fixed(&mut self, run_bits: u32) -> Option<()> {
        let mut litlen = [8u8; LITLEN_CODES];
        litlen[144..256].fill(9);
        litlen[256..280].fill(7);
        self.build(&litlen, &[5; 32], run_bits)
    }

    /// Reads a dynamic block's header (RFC 1951 §3.2.7) and builds its codes.
    fn read_dynamic(&mut self, bits: &mut Bits<'_>, run_bits: u32) -> Option<()> {
        bits.refill();
        let litlen_count = bits.take(5) + 257;
        let distance_count = bits.take(5) + 1;
        let code_length_count = bits.take(4) + 4;
        if litlen_count > LITLEN_SYMBOLS || distance_count > DISTANCE_SYMBOLS {
            return None;
        }
        let mut code_length_lengths = [0u8; 19];
        for &symbol in &CODE_LENGTH_ORDER[..code_length_count] {
            bits.refill();
            code_length_lengths[symbol] = bits.take(3) as u8;
        }
        let code_lengths = &mut self.code_lengths;
        code_lengths.build(&code_length_lengths, Completeness::Complete, 1)?;
        let mut lengths = [0u8; LITLEN_SYMBOLS + DISTANCE_SYMBOLS];
        let declared = litlen_count + distance_count;
        let mut i = 0;
        while i < declared {
            bits.refill();
            // Code length codes are at most 7 bits: always in the table.
            let (symbol, length) = code_lengths.peek(bits)?;
            bits.consume(length);
            let (value, repeat) = match symbol {
                length @ 0..=15 => (length as u8, 1),
                16 => (*lengths.get(i.checked_sub(1)?)?, 3 + bits.take(2)),
                17 => (0, 3 + bits.take(3)),
                _ => (0, 11 + bits.take(7)),
            };
            lengths.get_mut(i..i + repeat)?.fill(value);
            i += repeat;
        }
        if i != declared {
            return None; // a repeat ran past the declared lengths
        }
        let (litlen_lengths, distance_lengths) = lengths[..declared].split_at(litlen_count);
        if litlen_lengths[usize::from(END_OF_BLOCK)] == 0 {
            return None;
        }
        self.build(litlen_lengths, distance_lengths, run_bits)
    }
}

/// Inflates one Huffman block's data into `out` from `written` on; how far `out` is written
/// after it.
fn inflate_block(
    stream: &mut Bits<'_>,
    tables: &Tables,
    out: &mut [u8],
    written: usize,
    report: &mut Report<'_>,
) -> Option<usize> {
    // The look-ups a refill holds, a constant in each loop (unrolled).
    if tables.runs.per_refill >= LOOKUPS_MAX {
        inflate_block_by::<LOOKUPS_MAX>(stream, tables, out, written, report)
    } else {
        inflate_block_by::<4>(stream, tables, out, written, report)
    }
}

/// [`inflate_block`] with `PER_REFILL` run look-ups a refill.
fn inflate_block_by<const PER_REFILL: usize>(
    stream: &mut Bits<'_>,
    tables: &Tables,
    out: &mut [u8],
    mut written: usize,
    report: &mut Report<'_>,
) -> Option<usize> {
    // A copy of the stream's state, which the compiler keeps in registers.
    let mut local = *stream;
    let bits = &mut local;
    loop {
        report.check(&out[..written]);
        bits.refill();
        // Literal runs: as many look-ups a refill as the 56 bits hold (four of 12 bits, six
        // of 9), each writing four bytes (its run, then bytes the next run overwrites), while
        // 24 + 1 bytes are left.
        if let Some(window) = out.get_mut(written..written + 4 * PER_REFILL + 1) {
            // The look-ups' `meta` summed: the runs' bits (at most 54) stay in the low six
            // bits, their literal counts less one gather above. The buffer shifts by each
            // `meta` unmasked ([`Bits::shift_buffer`]); the count follows after the loop.
            let (mut lookups, mut taken) = (0, 0u32);
            while lookups < PER_REFILL {
                let index = tables.runs.index(bits);
                let meta = u32::from(tables.runs.meta[index]);
                if meta == 0 {
                    break;
                }
                let literals = tables.runs.bytes[index].to_le_bytes();
                let at = (taken >> 6) as usize + lookups;
                window[at..at + 4].copy_from_slice(&literals);
                bits.shift_buffer(meta);
                taken += meta;
                lookups += 1;
            }
            bits.count -= taken & 63;
            written += (taken >> 6) as usize + lookups;
            if lookups == PER_REFILL {
                continue;
            }
            bits.refill();
        }
        match symbol(bits, tables, out, written)? {
            Symbol::Wrote(after) => written = after,
            Symbol::EndOfBlock => {
                *stream = *bits;
                return Some(written);
            }
        }
    }
}

/// What [`symbol`] decoded.
enum Symbol {
    /// A literal or a match, `out` written up to here.
    Wrote(usize),
    /// The block's end.
    EndOfBlock,
}

/// Decodes one symbol of a Huffman block whose output reached `written` (the caller refilled
/// the buffer): a length and its distance (the match copied), the block's end, or a literal
/// near the end of `out` (or of more than 12 bits). `None` for a stream that is not valid.
#[inline(always)]
fn symbol(bits: &mut Bits<'_>, tables: &Tables, out: &mut [u8], written: usize) -> Option<Symbol> {
    let (symbol, length) = tables.litlen.peek(bits)?;
    bits.consume(length);
    if symbol < usize::from(END_OF_BLOCK) {
        *out.get_mut(written)? = symbol as u8;
        return Some(Symbol::Wrote(written + 1));
    }
    if symbol == usize::from(END_OF_BLOCK) {
        return Some(Symbol::EndOfBlock);
    }
    // A length (at most 15 + 5 bits) and a distance (15 + 13): 48 of the 56 bits.
    let which = symbol - 257;
    let extra = u32::from(*LENGTH_EXTRA.get(which)?);
    let copy = usize::from(LENGTH_BASE[which]) + bits.take(extra);
    let (symbol, length) = tables.distance.peek(bits)?;
    if symbol >= DISTANCE_SYMBOLS {
        return None;
    }
    bits.consume(length);
    let back = usize::from(DISTANCE_BASE[symbol]) + bits.take(u32::from(DISTANCE_EXTRA[symbol]));
    let from = written.checked_sub(back)?;
    let end = written + copy;
    if end > out.len() {
        return None;
    }
    if back >= copy {
        out.copy_within(from..from + copy, written);
    } else if back == 1 {
        let byte = out[from];
        out[written..end].fill(byte);
    } else {
        // Overlapping: each byte is one the copy itself wrote `back` earlier.
        for i in written..end {
            out[i] = out[i - back];
        }
    }
    Some(Symbol::Wrote(end))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use std::io::Write as _;

    /// What fdeflate (the general decoder) makes of `stream`: the output when it is a whole
    /// valid stream of exactly `len` bytes, Adler-32 aside.
    fn reference(stream: &[u8], len: usize) -> Option<Vec<u8>> {
        let mut out = vec![0; len];
        let mut decoder = fdeflate::Decompressor::new();
        decoder.ignore_adler32();
        let (mut input, mut written) = (stream, 0);
        while !decoder.is_done() {
            let (used, wrote) = decoder.read(input, &mut out, written, true).ok()?;
            if used == 0 && wrote == 0 && !decoder.is_done() {
                return None;
            }
            input = &input[used..];
            written += wrote;
        }
        (input.is_empty() && written == len).then_some(out)
    }

    fn ours(stream: &[u8], len: usize) -> Option<Vec<u8>> {
        let mut out = vec![0xAA; len];
        let mut shown = 0;
        let taken = inflate_zlib(stream, &mut out, 1000, |done| {
            assert!(done.len() >= shown, "progress went back");
            shown = done.len();
        });
        taken.map(|()| {
            assert_eq!(shown, len, "the whole output shown at the end");
            out
        })
    }

    /// Rows of a noisy frame with bright blobs, Sub-filtered as the simulator writes them.
    fn filtered_noise(width: usize, height: usize, sigma: f64, seed: u64) -> Vec<u8> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut rows = Vec::with_capacity((width + 1) * height);
        for y in 0..height {
            rows.push(1);
            let mut left = 0u8;
            for x in 0..width {
                let blob = (x as i64 - 40).pow(2) + (y as i64 - 20).pow(2) < 64;
                let noise: f64 = (0..4).map(|_| rng.random::<f64>() - 0.5).sum::<f64>() * sigma;
                let value = if blob {
                    255
                } else {
                    (12.0 + noise).clamp(0.0, 255.0) as u8
                };
                rows.push(value.wrapping_sub(left));
                left = value;
            }
        }
        rows
    }

    fn fdeflate_stream(data: &[u8]) -> Vec<u8> {
        fdeflate::compress_to_vec(data)
    }

    fn zlib_stream(data: &[u8], level: u32) -> Vec<u8> {
        let mut encoder =
            flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::new(level));
        encoder.write_all(data).expect("in memory");
        encoder.finish().expect("in memory")
    }

    /// Two streams inflated side by side, each with its own output, pieces and progress
    /// (checked to go forward and to end on the whole output when taken).
    fn ours_pair(a: (&[u8], usize), b: (&[u8], usize)) -> [Option<Vec<u8>>; 2] {
        let (mut out_a, mut out_b) = (vec![0xAA; a.1], vec![0x55; b.1]);
        let (mut shown_a, mut shown_b) = (0, 0);
        let mut progress_a = |done: &[u8]| {
            assert!(done.len() >= shown_a, "progress went back");
            shown_a = done.len();
        };
        let mut progress_b = |done: &[u8]| {
            assert!(done.len() >= shown_b, "progress went back");
            shown_b = done.len();
        };
        let [taken_a, taken_b] = inflate_zlib_pair(
            [a.0, b.0],
            [&mut out_a, &mut out_b],
            [1000, 337],
            [&mut progress_a, &mut progress_b],
        );
        if taken_a.is_some() {
            assert_eq!(shown_a, a.1, "the whole output shown at the end");
        }
        if taken_b.is_some() {
            assert_eq!(shown_b, b.1, "the whole output shown at the end");
        }
        [taken_a.map(|()| out_a), taken_b.map(|()| out_b)]
    }

    #[test]
    fn two_streams_inflated_side_by_side_give_what_each_gives_alone() {
        // Streams of every kind this decoder meets: fdeflate's one block of 12-bit runs,
        // zlib's stored, fixed and dynamic blocks of 9-bit runs with matches and codes longer
        // than the table, of different lengths (one ends while the other goes on), and
        // damaged or cut ones (refused, or whatever a reading alone makes of them).
        let noise = filtered_noise(640, 40, 2.5, 31);
        let small = filtered_noise(97, 23, 1.5, 32);
        let skewed_data = skewed(60_000, 33);
        let mut streams: Vec<(Vec<u8>, usize)> = vec![
            (fdeflate_stream(&noise), noise.len()),
            (fdeflate_stream(&small), small.len()),
            (zlib_stream(&noise, 1), noise.len()),
            (zlib_stream(&noise, 6), noise.len()),
            (zlib_stream(&noise, 0), noise.len()),
            (zlib_stream(&skewed_data, 9), skewed_data.len()),
            (zlib_stream(b"abcabcabcabd", 6), 12),
            (zlib_stream(&[], 6), 0),
        ];
        let mut cut = streams[3].0.clone();
        cut.truncate(cut.len() / 2);
        streams.push((cut, noise.len()));
        let mut flipped = streams[2].0.clone();
        flipped[900] ^= 0x10;
        streams.push((flipped, noise.len()));
        let long = streams[2].0.clone();
        streams.push((long, noise.len() - 1));
        let mut taken_together = 0;
        for (a, len_a) in &streams {
            for (b, len_b) in &streams {
                let alone = [ours(a, *len_a), ours(b, *len_b)];
                let together = ours_pair((a, *len_a), (b, *len_b));
                assert_eq!(together, alone);
                taken_together += usize::from(together.iter().all(Option::is_some));
            }
        }
        assert!(taken_together >= 60, "{taken_together} pairs both taken");
    }

    #[test]
    fn frames_written_by_fdeflate_inflate_as_fdeflate_inflates_them() {
        for (width, height, sigma, seed) in [
            (1280, 64, 2.0, 1),
            (333, 41, 6.0, 2),
            (1, 9, 1.0, 3),
            (64, 64, 0.0, 4),
        ] {
            let data = filtered_noise(width, height, sigma, seed);
            let stream = fdeflate_stream(&data);
            let got = ours(&stream, data.len());
            assert!(got.is_some(), "{width}x{height} sigma {sigma}: refused");
            assert_eq!(got, Some(data.clone()));
            assert_eq!(reference(&stream, data.len()), Some(data));
        }
    }

    #[test]
    fn matches_of_every_kind_inflate_as_zlib_wrote_them() {
        // Few distinct bytes (short codes) with repeats near and far: zlib's levels write
        // lengths and distances of many sizes, overlapping copies, several blocks.
        let (mut taken, mut tried) = (0, 0);
        for (size, seed) in [(3_000, 7), (20_000, 8), (150_000, 9)] {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut data: Vec<u8> = (0..size).map(|_| rng.random_range(0..4u8) * 3).collect();
            for _ in 0..size / 20 {
                let len = rng.random_range(3..300).min(size / 4);
                let from = rng.random_range(0..size - len);
                let to = rng.random_range(0..size - len);
                let piece = data[from..from + len].to_vec();
                data[to..to + len].copy_from_slice(&piece);
            }
            data.extend(std::iter::repeat_n(7u8, 1_000));
            data.extend((0..900).map(|i| [1u8, 2, 3][i % 3]));
            for level in 1..=9 {
                let stream = zlib_stream(&data, level);
                tried += 1;
                let got = ours(&stream, data.len());
                if let Some(got) = got {
                    assert!(got == data, "{size} bytes, level {level}: wrong bytes");
                    taken += 1;
                }
            }
        }
        assert!(taken * 2 >= tried, "only {taken} of {tried} streams taken");
    }

    #[test]
    fn streams_it_does_not_take_or_that_are_wrong_are_refused() {
        let data = filtered_noise(200, 30, 3.0, 6);
        let stream = fdeflate_stream(&data);
        // Short and long output, cut and extended streams, no Adler-32.
        assert_eq!(ours(&stream, data.len() - 1), None);
        assert_eq!(ours(&stream, data.len() + 1), None);
        assert_eq!(ours(&stream[..stream.len() - 5], data.len()), None);
        assert_eq!(ours(&stream[..stream.len() - 4], data.len()), None);
        let mut longer = stream.clone();
        longer.push(0);
        assert_eq!(ours(&longer, data.len()), None);
        // Block type 3 (reserved): the first block's header bits 1-2 set to 11.
        let mut reserved = stream.clone();
        reserved[2] |= 0b110;
        assert_eq!(ours(&reserved, data.len()), None);
        // A preset dictionary, a bad header check.
        let mut dictionary = stream.clone();
        dictionary[1] |= 0x20;
        assert_eq!(ours(&dictionary, data.len()), None);
        let mut check = stream;
        check[1] ^= 1;
        assert_eq!(ours(&check, data.len()), None);
    }

    /// Bytes whose frequencies halve from one value to the next: the rare ones get codes
    /// longer than 12 bits (up to deflate's 15).
    fn skewed(size: usize, seed: u64) -> Vec<u8> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..size)
            .map(|_| {
                let mut value = 0u8;
                while value < 60 && rng.random_bool(0.5) {
                    value += 1;
                }
                value.wrapping_mul(37)
            })
            .collect()
    }

    /// The first block's tables, when it is a dynamic block.
    fn first_block_tables(stream: &[u8]) -> Option<Tables> {
        let mut bits = Bits {
            input: &stream[2..],
            next: 0,
            buffer: 0,
            count: 0,
        };
        bits.refill();
        bits.consume(1);
        let mut tables = Tables::empty();
        (bits.take(2) == 2 && tables.read_dynamic(&mut bits, TABLE_BITS).is_some())
            .then_some(tables)
    }

    #[test]
    fn codes_longer_than_the_table_inflate_as_zlib_wrote_them() {
        let mut long_codes = 0;
        for (size, seed) in [(5_000, 1), (60_000, 2), (400_000, 3)] {
            let data = skewed(size, seed);
            for level in [1, 6, 9] {
                let stream = zlib_stream(&data, level);
                let tables = first_block_tables(&stream).expect("a dynamic block");
                long_codes += usize::from(tables.litlen.has_long_codes());
                assert_eq!(
                    ours(&stream, data.len()),
                    Some(data.clone()),
                    "{size} level {level}"
                );
            }
        }
        // (5 000 bytes of this kind are too few for codes over 12 bits; the larger are not.)
        assert!(
            long_codes >= 2,
            "{long_codes} streams with codes over 12 bits"
        );
    }

    /// An index's run by its definition: literals decoded one at a time while their codes
    /// lie whole in the index (the bits past it read as zeros), up to four: (how many, their
    /// bits, the literals).
    fn run_by_definition(single: &SymbolTable, index: usize, index_bits: u32) -> (u32, u32, u32) {
        let (mut count, mut bits, mut bytes) = (0, 0, 0);
        while count < RUN_MAX {
            let entry = single[index >> bits];
            let (symbol, length) = (u32::from(entry >> 4), u32::from(entry & 15));
            if length == 0 || symbol >= 256 || bits + length > index_bits {
                break;
            }
            bytes |= symbol << (8 * count);
            bits += length;
            count += 1;
        }
        (count, bits, bytes)
    }

    #[test]
    fn each_run_is_what_decoding_its_index_literal_by_literal_gives() {
        // The runs are built from the runs already built, without branches.
        let mut checked = 0;
        for (data, level) in [
            (filtered_noise(640, 48, 2.5, 21), 1),
            (filtered_noise(640, 48, 0.7, 23), 1),
            (skewed(60_000, 22), 6),
        ] {
            let stream = zlib_stream(&data, level);
            let mut tables = first_block_tables(&stream).expect("a dynamic block");
            for index_bits in [8, 9, 10, 12] {
                tables.runs.build(&tables.litlen.table, index_bits);
                for index in 0..1usize << index_bits {
                    let (count, bits, bytes) =
                        run_by_definition(&tables.litlen.table, index, index_bits);
                    let meta = u32::from(tables.runs.meta[index]);
                    let at = format!("level {level}, {index_bits} bits, index {index}");
                    if count == 0 {
                        assert_eq!(meta, 0, "{at}");
                        continue;
                    }
                    assert_eq!((meta >> 6) + 1, count, "{at}");
                    assert_eq!(meta & 63, bits, "{at}");
                    let mask = u32::MAX >> (32 - 8 * count);
                    assert_eq!(tables.runs.bytes[index] & mask, bytes, "{at}");
                    checked += 1;
                }
            }
        }
        assert!(checked > 5_000, "{checked} runs");
    }

    #[test]
    fn stored_fixed_and_many_blocks_inflate_as_written() {
        let noise = filtered_noise(300, 200, 3.0, 11);
        // Level 0: stored blocks only (and one empty stored block at the end for some
        // writers); a few bytes: one fixed-code block; zlib's levels on 60 KB: several blocks.
        for (data, level) in [
            (noise.clone(), 0),
            (b"abcabcabcabd".to_vec(), 6),
            (vec![9u8; 5], 1),
            (Vec::new(), 6),
            (noise, 1),
        ] {
            let stream = zlib_stream(&data, level);
            assert_eq!(
                ours(&stream, data.len()),
                Some(data.clone()),
                "level {level}"
            );
        }
        // The fixed block's own header bits: 01 after the last-block bit.
        let fixed = zlib_stream(b"abcabcabcabd", 6);
        assert_eq!((fixed[2] >> 1) & 3, 1, "not a fixed block");
        // A stored block whose length check (NLEN) is wrong.
        let mut stored = zlib_stream(&[5u8; 100], 0);
        stored[5] ^= 1;
        assert_eq!(ours(&stored, 100), None);
        assert_eq!(reference(&stored, 100), None);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]
        /// A damaged stream is refused, or, when it still is a whole deflate stream, gives
        /// what fdeflate gives: never other bytes.
        #[test]
        fn a_damaged_stream_is_refused_or_inflated_as_fdeflate_does(
            seed in 0u64..1_000,
            flips in proptest::collection::vec((0usize..10_000, 0u8..8), 1..4),
            level in 0u32..11,
        ) {
            // Level 10 stands for fdeflate's stream, 0–9 for zlib's levels (stored, fixed for
            // the skewed short ones, dynamic with long codes).
            let data = if seed % 2 == 0 {
                filtered_noise(97, 23, 2.5, seed)
            } else {
                skewed(2_000 + seed as usize, seed)
            };
            let mut stream = if level < 10 {
                zlib_stream(&data, level)
            } else {
                fdeflate_stream(&data)
            };
            for (at, bit) in flips {
                let at = 2 + at % (stream.len() - 2);
                stream[at] ^= 1 << bit;
            }
            let alone = ours(&stream, data.len());
            if let Some(got) = &alone {
                prop_assert_eq!(Some(got.clone()), reference(&stream, data.len()));
            }
            // Beside an undamaged stream, each gives what it gives alone.
            let clean = fdeflate_stream(&data);
            let [damaged, undamaged] = ours_pair((&stream, data.len()), (&clean, data.len()));
            prop_assert_eq!(damaged, alone);
            prop_assert_eq!(undamaged, Some(data.clone()));
        }
    }
}
