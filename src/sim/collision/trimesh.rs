//! Triangle-mesh colliders: the triangles in local space and a bounding
//! volume hierarchy over them, so a query touches `O(log n)` triangles and a
//! 10 000-triangle table costs about what a 12-triangle one does.

use bevy::math::Vec3;
use bevy::shape::Aabb3d;

use crate::error::ClothError;

/// Triangles per BVH leaf.
const LEAF: usize = 4;

/// One BVH node: a box and either two children or a run of triangles.
#[derive(Clone, Debug)]
struct Node {
    min: Vec3,
    max: Vec3,
    /// Leaf: index of the first triangle in `order`; inner: left child.
    start: u32,
    /// Leaf: triangle count (> 0); inner: 0.
    count: u32,
    /// Inner: right child.
    right: u32,
}

/// A triangle soup in a collider's local frame (m) with its BVH.
#[derive(Clone, Debug)]
pub struct TriMesh {
    /// Triangle corners, local space, m.
    pub triangles: Vec<[Vec3; 3]>,
    /// Unit face normals (from the winding, counter-clockwise = front).
    pub normals: Vec<Vec3>,
    nodes: Vec<Node>,
    order: Vec<u32>,
}

impl TriMesh {
    /// Builds the mesh and its BVH from triangles in local space (m).
    /// Degenerate (zero-area) and non-finite triangles are dropped.
    pub fn new(triangles: impl IntoIterator<Item = [Vec3; 3]>) -> Result<Self, ClothError> {
        let mut tris = Vec::new();
        let mut normals = Vec::new();
        for t in triangles {
            let n = (t[1] - t[0]).cross(t[2] - t[0]);
            if t.iter().all(|v| v.is_finite()) && n.length_squared() > 1e-20 {
                tris.push(t);
                normals.push(n.normalize());
            }
        }
        if tris.is_empty() {
            return Err(ClothError::InvalidCollider(
                "a mesh collider needs at least one triangle",
            ));
        }
        let mut mesh = Self {
            order: (0..tris.len() as u32).collect(),
            triangles: tris,
            normals,
            nodes: Vec::new(),
        };
        let n = mesh.order.len();
        mesh.build(0, n);
        Ok(mesh)
    }

    /// The box around every triangle (local, m).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (self.nodes[0].min, self.nodes[0].max)
    }

    fn build(&mut self, start: usize, end: usize) -> u32 {
        let (mut min, mut max) = (Vec3::MAX, Vec3::MIN);
        let (mut cmin, mut cmax) = (Vec3::MAX, Vec3::MIN);
        for &t in &self.order[start..end] {
            let tri = &self.triangles[t as usize];
            for v in tri {
                min = min.min(*v);
                max = max.max(*v);
            }
            let c = (tri[0] + tri[1] + tri[2]) / 3.0;
            cmin = cmin.min(c);
            cmax = cmax.max(c);
        }
        let id = self.nodes.len() as u32;
        self.nodes.push(Node {
            min,
            max,
            start: start as u32,
            count: (end - start) as u32,
            right: 0,
        });
        if end - start <= LEAF {
            return id;
        }
        // Split at the median centroid along the widest axis.
        let axis = (cmax - cmin).max_position();
        let centroid = |t: &u32| {
            let tri = &self.triangles[*t as usize];
            (tri[0][axis] + tri[1][axis] + tri[2][axis]) / 3.0
        };
        let mid = (start + end) / 2;
        let mut slice = std::mem::take(&mut self.order);
        slice[start..end]
            .select_nth_unstable_by(mid - start, |a, b| centroid(a).total_cmp(&centroid(b)));
        self.order = slice;
        let left = self.build(start, mid);
        let right = self.build(mid, end);
        let node = &mut self.nodes[id as usize];
        node.start = left;
        node.count = 0;
        node.right = right;
        id
    }

    /// Calls `f(triangle index)` for every triangle whose box overlaps the
    /// box `[min, max]` (local, m). No allocation.
    pub fn query(&self, min: Vec3, max: Vec3, mut f: impl FnMut(usize)) {
        let mut stack = [0u32; 64];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            if node.max.cmplt(min).any() || node.min.cmpgt(max).any() {
                continue;
            }
            if node.count > 0 {
                for &t in &self.order[node.start as usize..(node.start + node.count) as usize] {
                    let [a, b, c] = &self.triangles[t as usize];
                    if a.max(*b).max(*c).cmpge(min).all() && a.min(*b).min(*c).cmple(max).all() {
                        f(t as usize);
                    }
                }
            } else if top + 2 <= stack.len() {
                stack[top] = node.start;
                stack[top + 1] = node.right;
                top += 2;
            }
        }
    }

    /// The axis-aligned box of triangle `t`.
    pub fn triangle_box(&self, t: usize) -> Aabb3d {
        let [a, b, c] = self.triangles[t];
        Aabb3d {
            min: a.min(b).min(c).into(),
            max: a.max(b).max(c).into(),
        }
    }
}

/// The point of triangle `[a, b, c]` closest to `p` (Ericson, *Real-Time
/// Collision Detection*, §5.1.5).
pub fn closest_point_on_triangle(p: Vec3, [a, b, c]: [Vec3; 3]) -> Vec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// Where the segment `p0 → p1` crosses triangle `[a, b, c]`, as the fraction
/// `t ∈ [0, 1]` along it (Möller–Trumbore), or `None`.
pub fn segment_triangle(p0: Vec3, p1: Vec3, [a, b, c]: [Vec3; 3]) -> Option<f32> {
    let dir = p1 - p0;
    let (e1, e2) = (b - a, c - a);
    let h = dir.cross(e2);
    let det = e1.dot(h);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv = 1.0 / det;
    let s = p0 - a;
    let u = inv * s.dot(h);
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = inv * dir.dot(q);
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = inv * e2.dot(q);
    (0.0..=1.0).contains(&t).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::mesh::{MeshBuilder, Meshable};
    use bevy::shape::{Cuboid, Sphere};

    #[test]
    fn bvh_query_finds_exactly_the_overlapping_triangles() {
        let mesh = Sphere::new(1.0).mesh().ico(10).unwrap();
        let tm = TriMesh::from_mesh(&mesh).unwrap();
        assert!(tm.triangles.len() > 2000);
        for (min, max) in [
            (Vec3::splat(-0.1), Vec3::splat(0.1)),
            (Vec3::new(0.9, -0.1, -0.1), Vec3::new(1.1, 0.1, 0.1)),
            (Vec3::splat(-2.0), Vec3::splat(2.0)),
            (Vec3::splat(5.0), Vec3::splat(6.0)),
        ] {
            let mut got = Vec::new();
            tm.query(min, max, |t| got.push(t));
            got.sort_unstable();
            let want: Vec<usize> = (0..tm.triangles.len())
                .filter(|&t| {
                    let b = tm.triangle_box(t);
                    Vec3::from(b.max).cmpge(min).all() && Vec3::from(b.min).cmple(max).all()
                })
                .collect();
            assert_eq!(got, want, "box {min}..{max}");
        }
    }

    #[test]
    fn closest_points_and_crossings() {
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Z];
        let above = closest_point_on_triangle(Vec3::new(0.2, 1.0, 0.2), tri);
        assert!((above - Vec3::new(0.2, 0.0, 0.2)).length() < 1e-6);
        assert_eq!(
            closest_point_on_triangle(Vec3::new(-1.0, 0.0, -1.0), tri),
            Vec3::ZERO
        );
        let on_edge = closest_point_on_triangle(Vec3::new(1.0, 0.0, 1.0), tri);
        assert!((on_edge - Vec3::new(0.5, 0.0, 0.5)).length() < 1e-6);
        let t = segment_triangle(Vec3::new(0.2, 1.0, 0.2), Vec3::new(0.2, -3.0, 0.2), tri).unwrap();
        assert!((t - 0.25).abs() < 1e-6);
        assert_eq!(
            segment_triangle(Vec3::new(2.0, 1.0, 2.0), Vec3::new(2.0, -1.0, 2.0), tri),
            None
        );
        assert_eq!(
            segment_triangle(Vec3::new(0.2, 1.0, 0.2), Vec3::new(0.2, 0.5, 0.2), tri),
            None
        );
    }

    #[test]
    fn cuboid_mesh_normals_point_outwards_and_bad_meshes_are_errors() {
        let tm = TriMesh::from_mesh(&Cuboid::new(2.0, 0.1, 1.0).mesh().build()).unwrap();
        for (tri, n) in tm.triangles.iter().zip(&tm.normals) {
            let centre = (tri[0] + tri[1] + tri[2]) / 3.0;
            assert!(centre.dot(*n) > 0.0, "inward normal {n} at {centre}");
        }
        let (min, max) = tm.bounds();
        assert!((max - Vec3::new(1.0, 0.05, 0.5)).length() < 1e-6 && (min + max).length() < 1e-6);
        assert!(TriMesh::new([[Vec3::ZERO; 3]]).is_err());
        assert!(TriMesh::new(Vec::new()).is_err());
    }
}
