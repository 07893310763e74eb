//! The `.oni` file format, just enough to repair one trap of Debian's OpenNI2 2.2.0.33.
//!
//! A `.oni` recorded from a stream without a cropping property (the `Dummy` device, and
//! any driver that does not implement cropping) lacks the `Cropping`/`xnCropping`
//! property records. OpenNI2's file player then drops every frame of that stream
//! without a word, and `read_frame` blocks forever. [`add_missing_cropping`] inserts the
//! two records (cropping off), exactly as OpenNI2's own recorder writes them for a
//! PS1080, and moves every file position stored after the insertion (seek tables, undo
//! positions) along. Pure Rust, so it is tested without the OpenNI2 runtime.
//!
//! Layout (little-endian, packed): a 24-byte file header (`NI10`, version, max
//! timestamp, max node id), then records: `magic "NIR\0", type, node id, fields size
//! (including this 28-byte header), payload size: u32; undo position: u64`, fields,
//! payload.

const FILE_HEADER: usize = 24;
const RECORD_HEADER: usize = 28;
const RECORD_MAGIC: u32 = 0x0052_494E;

const RECORD_INT_PROPERTY: u32 = 0x03;
const RECORD_GENERAL_PROPERTY: u32 = 0x06;
const RECORD_NODE_STATE_READY: u32 = 0x09;
const RECORD_NEW_DATA: u32 = 0x0A;
const RECORD_END: u32 = 0x0B;
const RECORD_NODE_ADDED_1_0_0_5: u32 = 0x0C;
const RECORD_NODE_ADDED: u32 = 0x0D;
const RECORD_SEEK_TABLE: u32 = 0x0E;
const NODE_TYPE_DEPTH: u32 = 2;
/// timestamp u64, configuration id u32, file position u64.
const SEEK_ENTRY: usize = 20;

/// Why a file is not an `.oni` we can read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OniFileError {
    /// The file does not start as an `.oni` does.
    #[error("not an OpenNI recording (no NI10 header)")]
    NotOni,
    /// A record is cut short or inconsistent at this byte offset.
    #[error("damaged record at byte {0}")]
    Damaged(usize),
}

/// One record's place in the file.
#[derive(Debug, Clone, Copy)]
struct Record {
    pos: usize,
    kind: u32,
    node: u32,
    fields: usize,
    payload: usize,
}

impl Record {
    /// The file up to the end of this record's fields: a field read past them (a
    /// string whose length runs over) fails instead of reading the next record's bytes
    /// (found by the oni fuzz target: such a node's type came from the frame after it,
    /// and inserting the cropping before that frame made the node vanish).
    fn fields_of<'a>(&self, b: &'a [u8]) -> &'a [u8] {
        &b[..(self.pos + self.fields).min(b.len())]
    }
}

fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    b.get(at..at + 4)
        .map(|s| u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
}

fn u64_at(b: &[u8], at: usize) -> Option<u64> {
    b.get(at..at + 8).map(|s| {
        let mut a = [0u8; 8];
        a.copy_from_slice(s);
        u64::from_le_bytes(a)
    })
}

fn records(b: &[u8]) -> Result<Vec<Record>, OniFileError> {
    if b.len() < FILE_HEADER || &b[..4] != b"NI10" {
        return Err(OniFileError::NotOni);
    }
    let mut out = Vec::new();
    let mut pos = FILE_HEADER;
    while pos + RECORD_HEADER <= b.len() {
        let magic = u32_at(b, pos).ok_or(OniFileError::Damaged(pos))?;
        if magic != RECORD_MAGIC {
            // The recorder pads nothing: anything else ends what we can read.
            break;
        }
        let kind = u32_at(b, pos + 4).ok_or(OniFileError::Damaged(pos))?;
        let node = u32_at(b, pos + 8).ok_or(OniFileError::Damaged(pos))?;
        let fields = u32_at(b, pos + 12).ok_or(OniFileError::Damaged(pos))? as usize;
        let payload = u32_at(b, pos + 16).ok_or(OniFileError::Damaged(pos))? as usize;
        if fields < RECORD_HEADER || pos + fields + payload > b.len() {
            return Err(OniFileError::Damaged(pos));
        }
        out.push(Record {
            pos,
            kind,
            node,
            fields,
            payload,
        });
        if kind == RECORD_END {
            break;
        }
        pos += fields + payload;
    }
    Ok(out)
}

/// A length-prefixed string field (length includes the NUL) at `at`: (text, bytes used).
fn string_at(b: &[u8], at: usize) -> Option<(&[u8], usize)> {
    let len = u32_at(b, at)? as usize;
    let s = b.get(at + 4..at + 4 + len)?;
    let text = s.split(|&c| c == 0).next().unwrap_or(s);
    Some((text, 4 + len))
}

/// What a depth node of the file says about itself.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DepthNode {
    /// The node's id in the file.
    pub node: u32,
    /// Frames as the node-added record counts them (0 if the recorder never finished).
    pub frames: u32,
    /// Frames actually present (new-data records of this node).
    pub data_records: u32,
    /// Whether the file records the node's cropping, without which OpenNI2 plays nothing.
    pub has_cropping: bool,
}

/// The depth nodes of an `.oni` file.
pub fn depth_nodes(b: &[u8]) -> Result<Vec<DepthNode>, OniFileError> {
    let recs = records(b)?;
    let mut nodes: Vec<DepthNode> = Vec::new();
    for r in &recs {
        let f = r.pos + RECORD_HEADER;
        let b = r.fields_of(b);
        match r.kind {
            RECORD_NODE_ADDED | RECORD_NODE_ADDED_1_0_0_5 => {
                let (_, used) = string_at(b, f).ok_or(OniFileError::Damaged(r.pos))?;
                let node_type = u32_at(b, f + used).ok_or(OniFileError::Damaged(r.pos))?;
                let frames = u32_at(b, f + used + 8).ok_or(OniFileError::Damaged(r.pos))?;
                if node_type == NODE_TYPE_DEPTH {
                    nodes.retain(|n| n.node != r.node);
                    nodes.push(DepthNode {
                        node: r.node,
                        frames,
                        data_records: 0,
                        has_cropping: false,
                    });
                }
            }
            RECORD_GENERAL_PROPERTY => {
                if let Some((name, _)) = string_at(b, f) {
                    if name == b"xnCropping" {
                        if let Some(n) = nodes.iter_mut().find(|n| n.node == r.node) {
                            n.has_cropping = true;
                        }
                    }
                }
            }
            RECORD_NEW_DATA => {
                if let Some(n) = nodes.iter_mut().find(|n| n.node == r.node) {
                    n.data_records += 1;
                }
            }
            _ => {}
        }
    }
    Ok(nodes)
}

fn property_record(
    kind: u32,
    node: u32,
    undo: u64,
    name: &str,
    data: &[u8],
    out: &mut Vec<u8>,
) -> usize {
    let fields = RECORD_HEADER + 4 + name.len() + 1 + 4 + data.len();
    out.extend_from_slice(&RECORD_MAGIC.to_le_bytes());
    out.extend_from_slice(&kind.to_le_bytes());
    out.extend_from_slice(&node.to_le_bytes());
    out.extend_from_slice(&(fields as u32).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&undo.to_le_bytes());
    out.extend_from_slice(&(name.len() as u32 + 1).to_le_bytes());
    out.extend_from_slice(name.as_bytes());
    out.push(0);
    out.extend_from_slice(&(data.len() as u32).to_le_bytes());
    out.extend_from_slice(data);
    fields
}

/// A copy of the file with the cropping records added to every depth node that lacks
/// them, or `None` when no node needs them.
pub fn add_missing_cropping(b: &[u8]) -> Result<Option<Vec<u8>>, OniFileError> {
    let recs = records(b)?;
    let missing: Vec<u32> = depth_nodes(b)?
        .into_iter()
        .filter(|n| !n.has_cropping)
        .map(|n| n.node)
        .collect();
    if missing.is_empty() {
        return Ok(None);
    }
    // Insert before each such node's state-ready record (after its other properties),
    // or before its first frame when the recorder wrote no state-ready record; both
    // after the node's last node-added record, which starts its properties afresh (a
    // file adding a node twice was repaired before the second and needed it again).
    let mut inserts: Vec<(usize, u32)> = Vec::new();
    for node in missing {
        let added = recs
            .iter()
            .filter(|r| {
                r.node == node && matches!(r.kind, RECORD_NODE_ADDED | RECORD_NODE_ADDED_1_0_0_5)
            })
            .map(|r| r.pos)
            .next_back()
            .unwrap_or(0);
        let after = |kind: u32| {
            recs.iter()
                .find(|r| r.node == node && r.kind == kind && r.pos > added)
        };
        let at = after(RECORD_NODE_STATE_READY).or_else(|| after(RECORD_NEW_DATA));
        if let Some(r) = at {
            inserts.push((r.pos, node));
        }
    }
    if inserts.is_empty() {
        return Ok(None);
    }
    inserts.sort();
    // The records to insert, and how far each old position moves.
    let mut blocks: Vec<(usize, Vec<u8>)> = Vec::new();
    let mut shift_before = 0usize;
    for &(at, node) in &inserts {
        let new_at = (at + shift_before) as u64;
        let mut block = Vec::new();
        let int_len = property_record(
            RECORD_INT_PROPERTY,
            node,
            new_at,
            "Cropping",
            &1u64.to_le_bytes(),
            &mut block,
        );
        // XnCropping { XnBool enabled; u16 x, y, width, height } = 12 bytes, all off.
        property_record(
            RECORD_GENERAL_PROPERTY,
            node,
            new_at + int_len as u64,
            "xnCropping",
            &[0u8; 12],
            &mut block,
        );
        shift_before += block.len();
        blocks.push((at, block));
    }
    let moved = |old: u64| -> u64 {
        let extra: usize = blocks
            .iter()
            .filter(|(at, _)| (*at as u64) <= old)
            .map(|(_, blk)| blk.len())
            .sum();
        old + extra as u64
    };
    let mut out = b.to_vec();
    for r in &recs {
        // Undo positions point at earlier records of the same kind.
        let undo = u64_at(b, r.pos + 20).ok_or(OniFileError::Damaged(r.pos))?;
        if undo >= FILE_HEADER as u64 {
            out[r.pos + 20..r.pos + 28].copy_from_slice(&moved(undo).to_le_bytes());
        }
        let f = r.pos + RECORD_HEADER;
        match r.kind {
            RECORD_NODE_ADDED => {
                let (_, used) = string_at(r.fields_of(b), f).ok_or(OniFileError::Damaged(r.pos))?;
                // node type, codec, frames (u32), min, max timestamps (u64), seek table.
                let at = f + used + 12 + 16;
                if at + 8 <= r.pos + r.fields {
                    let seek = u64_at(b, at).ok_or(OniFileError::Damaged(r.pos))?;
                    if seek != 0 {
                        out[at..at + 8].copy_from_slice(&moved(seek).to_le_bytes());
                    }
                }
            }
            RECORD_SEEK_TABLE => {
                let start = r.pos + r.fields;
                for e in 0..r.payload / SEEK_ENTRY {
                    let at = start + e * SEEK_ENTRY + 12;
                    let pos = u64_at(b, at).ok_or(OniFileError::Damaged(r.pos))?;
                    if pos != 0 {
                        out[at..at + 8].copy_from_slice(&moved(pos).to_le_bytes());
                    }
                }
            }
            _ => {}
        }
    }
    // Splice the blocks in, last first so earlier offsets stay valid.
    for (at, block) in blocks.iter().rev() {
        out.splice(*at..*at, block.iter().copied());
    }
    Ok(Some(out))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header(kind: u32, node: u32, fields: usize, payload: usize, undo: u64) -> Vec<u8> {
        let mut v = Vec::new();
        for x in [RECORD_MAGIC, kind, node, fields as u32, payload as u32] {
            v.extend_from_slice(&x.to_le_bytes());
        }
        v.extend_from_slice(&undo.to_le_bytes());
        v
    }

    /// A miniature recording as the recorder writes one from a Dummy stream: node added
    /// (with a seek-table position), a property, state ready, data begin, frames, seek
    /// table, end.
    fn dummy_like(frames: u32, with_cropping: bool) -> (Vec<u8>, Vec<usize>) {
        let mut b = b"NI10".to_vec();
        b.extend_from_slice(&[2, 0, 0, 0, 0, 0, 0, 0]);
        b.extend_from_slice(&0u64.to_le_bytes());
        b.extend_from_slice(&1u32.to_le_bytes());
        let node_added_at = b.len();
        let name = b"Depth\0";
        let fields = RECORD_HEADER + 4 + name.len() + 4 * 3 + 8 * 3;
        b.extend(header(RECORD_NODE_ADDED, 1, fields, 0, 0));
        b.extend_from_slice(&(name.len() as u32).to_le_bytes());
        b.extend_from_slice(name);
        for x in [NODE_TYPE_DEPTH, 0x454E_4F4E, frames] {
            b.extend_from_slice(&x.to_le_bytes());
        }
        b.extend_from_slice(&0u64.to_le_bytes());
        b.extend_from_slice(&99u64.to_le_bytes());
        let seek_field = b.len();
        b.extend_from_slice(&0u64.to_le_bytes());
        let prop_at = b.len() as u64;
        property_record(
            RECORD_INT_PROPERTY,
            1,
            prop_at,
            "Mirror",
            &0u64.to_le_bytes(),
            &mut b,
        );
        if with_cropping {
            let at = b.len() as u64;
            property_record(
                RECORD_GENERAL_PROPERTY,
                1,
                at,
                "xnCropping",
                &[0; 12],
                &mut b,
            );
        }
        b.extend(header(RECORD_NODE_STATE_READY, 1, RECORD_HEADER, 0, 0));
        let mut frame_at = Vec::new();
        let mut last = 0u64;
        for i in 0..frames {
            frame_at.push(b.len());
            b.extend(header(RECORD_NEW_DATA, 1, RECORD_HEADER + 12, 4, last));
            last = *frame_at.last().unwrap() as u64;
            b.extend_from_slice(&(i as u64 * 33).to_le_bytes());
            b.extend_from_slice(&(i + 1).to_le_bytes());
            b.extend_from_slice(&[i as u8; 4]);
        }
        let seek_at = b.len() as u64;
        b.extend(header(
            RECORD_SEEK_TABLE,
            1,
            RECORD_HEADER,
            (frames as usize + 1) * SEEK_ENTRY,
            0,
        ));
        b.extend_from_slice(&[0; SEEK_ENTRY]);
        for (i, &at) in frame_at.iter().enumerate() {
            b.extend_from_slice(&(i as u64 * 33).to_le_bytes());
            b.extend_from_slice(&0u32.to_le_bytes());
            b.extend_from_slice(&(at as u64).to_le_bytes());
        }
        b[seek_field..seek_field + 8].copy_from_slice(&seek_at.to_le_bytes());
        b.extend(header(RECORD_END, 0, RECORD_HEADER, 0, 0));
        let _ = node_added_at;
        (b, frame_at)
    }

    #[test]
    fn a_file_without_cropping_gets_it_and_every_position_still_points_at_its_record() {
        let (b, _) = dummy_like(3, false);
        let nodes = depth_nodes(&b).unwrap();
        assert_eq!(
            nodes,
            vec![DepthNode {
                node: 1,
                frames: 3,
                data_records: 3,
                has_cropping: false
            }]
        );
        let fixed = add_missing_cropping(&b).unwrap().expect("needs a fix");
        let nodes = depth_nodes(&fixed).unwrap();
        assert!(nodes[0].has_cropping && nodes[0].data_records == 3);
        let recs = records(&fixed).unwrap();
        // The cropping records sit right before state-ready.
        let kinds: Vec<u32> = recs.iter().map(|r| r.kind).collect();
        assert_eq!(
            &kinds[..5],
            &[
                RECORD_NODE_ADDED,
                RECORD_INT_PROPERTY,
                RECORD_INT_PROPERTY,
                RECORD_GENERAL_PROPERTY,
                RECORD_NODE_STATE_READY
            ]
        );
        // The seek table position and every entry of it land on the right records.
        let added = recs[0];
        let (_, used) = string_at(&fixed, added.pos + RECORD_HEADER).unwrap();
        let seek = u64_at(&fixed, added.pos + RECORD_HEADER + used + 28).unwrap() as usize;
        let table = recs.iter().find(|r| r.kind == RECORD_SEEK_TABLE).unwrap();
        assert_eq!(seek, table.pos);
        let frames: Vec<&Record> = recs.iter().filter(|r| r.kind == RECORD_NEW_DATA).collect();
        for (i, f) in frames.iter().enumerate() {
            let at = table.pos + table.fields + (i + 1) * SEEK_ENTRY + 12;
            assert_eq!(
                u64_at(&fixed, at).unwrap() as usize,
                f.pos,
                "seek entry {i}"
            );
            if i > 0 {
                assert_eq!(
                    u64_at(&fixed, f.pos + 20).unwrap() as usize,
                    frames[i - 1].pos
                );
            }
            // Frame payloads are untouched.
            assert_eq!(
                &fixed[f.pos + f.fields..f.pos + f.fields + 4],
                &[i as u8; 4]
            );
        }
        // Fixing a fixed file changes nothing.
        assert_eq!(add_missing_cropping(&fixed).unwrap(), None);
    }

    /// Found by the oni fuzz target: a node added again after its frames. The cropping
    /// went before its first addition, which the second one undoes, so every repair
    /// added it once more; now it goes after the last addition (in the fuzzer's file
    /// nothing follows it: nothing to repair), and a repaired file needs no second one.
    #[test]
    fn a_node_added_twice_is_repaired_after_its_last_addition_once() {
        let b = include_bytes!("../../../fuzz/corpus/oni/node-added-twice.oni");
        assert_eq!(add_missing_cropping(b), Ok(None));
        let (mut twice, _) = dummy_like(2, false);
        let end = twice.len() - RECORD_HEADER;
        let (again, _) = dummy_like(2, false);
        twice.splice(
            end..end,
            again[FILE_HEADER..again.len() - RECORD_HEADER]
                .iter()
                .copied(),
        );
        let repaired = add_missing_cropping(&twice)
            .unwrap()
            .expect("needs cropping");
        assert!(depth_nodes(&repaired)
            .unwrap()
            .iter()
            .all(|n| n.has_cropping));
        assert_eq!(add_missing_cropping(&repaired), Ok(None));
    }

    /// Found by the oni fuzz target: a node-added record whose name's length runs past
    /// the record. Its fields are read within it, so the file is damaged, not a node
    /// whose type is read from the next record.
    #[test]
    fn a_field_running_past_its_record_is_damage() {
        let b = include_bytes!("../../../fuzz/corpus/oni/string-past-its-record.oni");
        assert_eq!(depth_nodes(b), Err(OniFileError::Damaged(24)));
        assert_eq!(add_missing_cropping(b), Err(OniFileError::Damaged(24)));
    }

    #[test]
    fn files_with_cropping_and_non_oni_files_are_left_alone() {
        let (b, _) = dummy_like(2, true);
        assert_eq!(add_missing_cropping(&b).unwrap(), None);
        assert_eq!(
            add_missing_cropping(b"hello world, not a recording"),
            Err(OniFileError::NotOni)
        );
        let (mut b, _) = dummy_like(2, false);
        // A record claiming more bytes than the file has.
        b[FILE_HEADER + 12] = 0xFF;
        b[FILE_HEADER + 13] = 0xFF;
        b[FILE_HEADER + 14] = 0xFF;
        assert!(matches!(
            add_missing_cropping(&b),
            Err(OniFileError::Damaged(_))
        ));
    }
}
