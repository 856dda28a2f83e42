//! The chunked parse: the text is cut into chunks at lines that start with an entity
//! keyword, the chunks are parsed in parallel, and their states are joined in file order.
//!
//! Why the result is exactly the serial parse's: a chunk starts at a keyword token, and a
//! serial parse that reaches that token either starts an entity there (what the chunk's
//! parser does) or has already failed, since a keyword is never a valid number, count or
//! view sub-keyword, so an entity that reads it fails on it. A chunk's parser reads an
//! entity that starts before the chunk's end to its own end, past the chunk's end if need
//! be, as the serial parse would; it stops at the first entity that starts at or after the
//! end. So the first error in file order is the first chunk's error, except where the
//! chunk has a `v` (met before its error, if any) and an earlier chunk had one too: that
//! is the serial parse's "second 'v'" error. Materials, lights, tallies, the background and
//! the view are joined by [`State::append`].

use std::path::Path;

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;

use rayon::prelude::*;

use super::cursor::{ends_token, Cursor};
use super::entities::Parser;
use super::state::{second_view, State, View};
use super::Loaded;
use crate::error::Error;
use crate::scene::Primitive;

/// Texts below this size are parsed serially.
const MIN_CHUNK_BYTES: usize = 1 << 20;

/// The size of a chunk of a large text: small enough that the threads, which take the
/// chunks in file order, keep few parsed chunks waiting to be joined.
const CHUNK_BYTES: usize = 4 << 20;

/// The chunk size for a text of `len` bytes: `usize::MAX` (one chunk) for a small text or
/// one thread.
pub(super) fn chunk_bytes(len: usize) -> usize {
    if len < 2 * MIN_CHUNK_BYTES || rayon::current_num_threads() < 2 {
        return usize::MAX;
    }
    let per_thread = len.div_ceil(rayon::current_num_threads());
    per_thread.clamp(MIN_CHUNK_BYTES, CHUNK_BYTES)
}

/// A parsed chunk: its state, and the error that stopped it.
type Parsed = (State, Option<Error>);

/// The chunks joined so far, in file order, and those parsed but not yet joined.
struct Joined {
    /// The state of chunks 0..next, once chunk 0 is joined.
    whole: Option<State>,
    next: usize,
    waiting: Vec<Option<Parsed>>,
    /// The first error in file order, once found.
    error: Option<Error>,
    /// Emptied primitive buffers of joined chunks, for the next chunks to fill: their
    /// memory is then written twice (there and in the whole) but allocated once.
    spare: Vec<Vec<Primitive>>,
}

impl Joined {
    /// Takes the parse of chunk `k` and joins every chunk that can now be joined in order.
    fn add(&mut self, path: &Path, k: usize, parsed: Parsed) {
        self.waiting[k] = Some(parsed);
        while self.error.is_none() {
            let Some((state, error)) = self.waiting.get_mut(self.next).and_then(Option::take) else {
                return;
            };
            self.next += 1;
            if let (Some(View { line: first, .. }), Some(line)) =
                (self.whole.as_ref().and_then(|w| w.view.as_ref()), state.first_view)
            {
                self.error = Some(second_view(path, line, *first));
            } else if error.is_some() {
                self.error = error;
            } else if let Some(whole) = &mut self.whole {
                self.spare.push(whole.append(state));
            } else {
                self.whole = Some(state);
            }
        }
    }
}

/// Parses `text` in chunks of about `chunk_bytes` bytes.
pub(super) fn parse(text: &str, path: &Path, chunk_bytes: usize) -> Result<Loaded, Error> {
    let starts = chunk_starts(text.as_bytes(), chunk_bytes);
    let mut ends: Vec<usize> = starts[1..].to_vec();
    ends.push(text.len());
    if starts.len() == 1 {
        let mut state = State::new(false);
        Parser::new(path, Cursor::new(text, 0, 1), text.len()).entities(&mut state)?;
        return state.finish(path);
    }
    // The line each chunk starts on.
    let newlines: Vec<usize> = (0..starts.len())
        .into_par_iter()
        .map(|k| count_newlines(&text.as_bytes()[starts[k]..ends[k]]))
        .collect();
    let lines: Vec<usize> = newlines
        .iter()
        .scan(1, |line, n| {
            let first = *line;
            *line += n;
            Some(first)
        })
        .collect();
    // Each thread takes the next chunk in file order; whoever completes the next chunk to
    // join joins it, so that parsed chunks do not pile up.
    let n = starts.len();
    let next = AtomicUsize::new(0);
    let waiting = (0..n).map(|_| None).collect();
    let joined = Mutex::new(Joined { whole: None, next: 0, waiting, error: None, spare: Vec::new() });
    let lock = || joined.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    let stop = AtomicBool::new(false);
    (0..rayon::current_num_threads().min(n)).into_par_iter().for_each(|_| loop {
        let k = next.fetch_add(1, Ordering::Relaxed);
        if k >= n || stop.load(Ordering::Relaxed) {
            return;
        }
        let mut state = State::new(k > 0);
        state.primitives = lock().spare.pop().unwrap_or_default();
        let cursor = Cursor::new(text, starts[k], lines[k]);
        let error = Parser::new(path, cursor, ends[k]).entities(&mut state).err();
        let mut joined = lock();
        joined.add(path, k, (state, error));
        if joined.error.is_some() {
            stop.store(true, Ordering::Relaxed);
        }
    });
    let joined = joined.into_inner().unwrap_or_else(|poisoned| poisoned.into_inner());
    match (joined.error, joined.whole) {
        (Some(error), _) => Err(error),
        (None, Some(whole)) => whole.finish(path),
        // Not met: without an error every chunk, the first included, is joined.
        (None, None) => parse(text, path, usize::MAX),
    }
}

/// The byte offsets where chunks start: 0, then about every `chunk_bytes` bytes, the start
/// of the next line that starts with an entity keyword token.
fn chunk_starts(bytes: &[u8], chunk_bytes: usize) -> Vec<usize> {
    let mut starts = vec![0];
    let mut target = chunk_bytes;
    while target < bytes.len() {
        // A line start at `target` or after it: a newline at `target - 1` or after it.
        let Some(start) = (target - 1..bytes.len() - 1)
            .find(|&i| bytes[i] == b'\n' && starts_with_keyword(&bytes[i + 1..]))
            .map(|i| i + 1)
        else {
            break;
        };
        starts.push(start);
        target = start.saturating_add(chunk_bytes);
    }
    starts
}

/// Whether `rest` starts with an entity keyword token (a keyword followed by whitespace,
/// `#` or the end of the text).
fn starts_with_keyword(rest: &[u8]) -> bool {
    let keyword = match rest {
        [b'p', b'p', ..] => 2,
        [b'v' | b'b' | b'l' | b'f' | b'c' | b's' | b'p', ..] => 1,
        _ => return false,
    };
    rest.get(keyword).is_none_or(|&b| ends_token(b))
}

/// The number of `\n` bytes, summed in byte counters over runs of 255 bytes (the most a
/// `u8` can count), which the compiler vectorises.
fn count_newlines(bytes: &[u8]) -> usize {
    bytes.chunks(255).map(|run| usize::from(run.iter().fold(0u8, |n, &b| n + u8::from(b == b'\n')))).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn newlines_are_counted_across_blocks() {
        let text: Vec<u8> =
            (0..20_000).map(|i| if i % 7 == 0 || i % 1000 < 300 { b'\n' } else { b'x' }).collect();
        for len in [0, 1, 31, 32, 33, 8159, 8160, 8161, 20_000] {
            let expected = text[..len].iter().filter(|&&b| b == b'\n').count();
            assert_eq!(count_newlines(&text[..len]), expected, "{len}");
        }
    }

    #[test]
    fn chunks_start_at_keyword_lines() {
        let text = b"v\nfrom 0 0 1\n  p 3\nppx 1\npp 3 1\n#c\ns\n";
        assert_eq!(chunk_starts(text, 1), vec![0, 25, 35]);
        assert_eq!(chunk_starts(text, 26), vec![0, 35]);
        assert_eq!(chunk_starts(text, 100), vec![0]);
    }
}
