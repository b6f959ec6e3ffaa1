//! The uniform grid of hash cells the self-collision, continuous and
//! between-cloths passes share: a point's cell and a cell's key.

use bevy::math::Vec3;

/// The cell (integer coordinates) of point `p` (m) for cells of side
/// `1 / inv_cell` m; saturating far from the origin.
pub(super) fn cell_of(p: Vec3, inv_cell: f32) -> [i32; 3] {
    let c = (p * inv_cell).floor();
    [c.x as i32, c.y as i32, c.z as i32]
}

/// The hash key of a cell.
pub(super) fn key([x, y, z]: [i32; 3]) -> u64 {
    (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
        ^ (z as u64).wrapping_mul(0x1656_67B1_9E37_79F9)
}

/// Items (triangles) by cell: entered as `(cell key, item)`, then counted
/// into buckets of a table twice as long as the entries (each bucket the
/// items of the cells whose keys share its top bits), so that a cell's
/// items are one slice away, without a sort. A bucket may hold items of
/// other cells too, and an item twice: users test what they take.
#[derive(Clone, Debug, Default)]
pub(super) struct CellTable {
    /// `(cell key, item)` as entered.
    entered: Vec<(u64, u32)>,
    /// Per bucket, where its items start in `items`, and their end last.
    starts: Vec<u32>,
    /// The items, bucket by bucket.
    items: Vec<u32>,
    /// How far a key is shifted right to give its bucket.
    shift: u32,
}

impl CellTable {
    /// Forgets every item.
    pub(super) fn clear(&mut self) {
        self.entered.clear();
        self.starts.clear();
        self.items.clear();
    }

    /// Enters `item` in the cell of key `key`; [`finish`](Self::finish)
    /// makes it found.
    pub(super) fn enter(&mut self, key: u64, item: u32) {
        self.entered.push((key, item));
    }

    /// Counts what was entered into the buckets.
    pub(super) fn finish(&mut self) {
        let bits = (2 * self.entered.len())
            .max(16)
            .next_power_of_two()
            .trailing_zeros();
        self.shift = 64 - bits;
        let shift = self.shift;
        self.starts.clear();
        self.starts.resize((1 << bits) + 1, 0);
        for &(k, _) in &self.entered {
            self.starts[(k >> shift) as usize + 1] += 1;
        }
        for b in 1..self.starts.len() {
            self.starts[b] += self.starts[b - 1];
        }
        self.items.clear();
        self.items.resize(self.entered.len(), 0);
        // Fill each bucket from its start, moving the starts on; they are
        // put back after.
        for &(k, item) in &self.entered {
            let slot = &mut self.starts[(k >> shift) as usize];
            self.items[*slot as usize] = item;
            *slot += 1;
        }
        for b in (1..self.starts.len()).rev() {
            self.starts[b] = self.starts[b - 1];
        }
        self.starts[0] = 0;
    }

    /// The items of the bucket of the cell of key `key` (with any other
    /// cells' sharing it).
    pub(super) fn cell(&self, key: u64) -> &[u32] {
        if self.starts.is_empty() {
            return &[];
        }
        let b = (key >> self.shift) as usize;
        &self.items[self.starts[b] as usize..self.starts[b + 1] as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every item entered is found in its cell's bucket, and a bucket
    /// holds nothing that was not entered in one of its cells.
    #[test]
    fn a_table_finds_each_item_in_its_cell() {
        let mut table = CellTable::default();
        assert!(table.cell(key([0, 0, 0])).is_empty());
        let mut entered = Vec::new();
        for item in 0..500u32 {
            for c in 0..(item % 5) {
                let cell = [item as i32 % 7 - 3, c as i32, -(item as i32 % 11)];
                table.enter(key(cell), item);
                entered.push((key(cell), item));
            }
        }
        table.finish();
        for &(k, item) in &entered {
            assert!(table.cell(k).contains(&item), "item {item} in its cell");
        }
        let total: usize = (0..1 << (64 - table.shift))
            .map(|b: u64| table.cell(b << table.shift).len())
            .sum();
        assert_eq!(total, entered.len(), "each entry once");
        table.clear();
        table.finish();
        assert!(table.cell(entered[0].0).is_empty());
    }
}
