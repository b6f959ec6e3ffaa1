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
