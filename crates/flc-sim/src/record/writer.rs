//! The recorder's writer thread: batches of encoded messages in, MCAP file out.

use super::*;

#[derive(Clone, Copy)]
pub(super) enum Ch {
    Scan,
    Detector,
    Lookahead,
    Tf,
    Track,
    Vehicles,
    State,
    Collisions,
}

pub(super) const N_CHANNELS: usize = 8;

pub(super) struct Channel {
    pub(super) id: u16,
    pub(super) sequence: u32,
}

pub(super) type McapWriter = mcap::Writer<BufWriter<File>>;

/// What the simulation thread hands to the writer thread: encoded messages back to back in one
/// buffer (no allocation per message; the writer thread hands emptied batches back for reuse).
#[derive(Default)]
pub(super) struct Batch {
    pub(super) data: Vec<u8>,
    pub(super) items: Vec<Item>,
}

pub(super) enum Item {
    Message(mcap::records::MessageHeader, std::ops::Range<usize>),
    Metadata(mcap::records::Metadata),
}

/// A batch goes to the writer thread once it holds this many messages or bytes.
pub(super) const BATCH_ITEMS: usize = 256;
pub(super) const BATCH_BYTES: usize = 256 << 10;
/// Batches queued for the writer thread at most (then the simulation waits for it).
pub(super) const QUEUE: usize = 8;

/// The writer thread: writes what arrives until the channel closes (or a write fails), then
/// finishes the file (summary, indexes, footer) and flushes it.
pub(super) fn writer_loop(mut w: McapWriter, rx: Receiver<Batch>, spare: Sender<Batch>) -> mcap::McapResult<()> {
    for mut batch in rx {
        for item in batch.items.drain(..) {
            match item {
                Item::Message(header, range) => w.write_to_known_channel(&header, &batch.data[range])?,
                Item::Metadata(m) => w.write_metadata(&m)?,
            }
        }
        batch.data.clear();
        let _ = spare.send(batch);
    }
    w.finish()?;
    w.into_inner().flush()?;
    Ok(())
}

pub(super) fn add_channel<T: Encode>(w: &mut McapWriter, topic: &str) -> mcap::McapResult<Channel> {
    let schema_id = match T::get_schema() {
        Some(s) => w.add_schema(&s.name, &s.encoding, &s.data)?,
        None => 0,
    };
    let id = w.add_channel(schema_id, topic, &T::get_message_encoding(), &BTreeMap::new())?;
    Ok(Channel { id, sequence: 0 })
}
