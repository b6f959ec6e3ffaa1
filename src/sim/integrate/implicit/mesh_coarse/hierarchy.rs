//! The hierarchy of a mesh cloth's multigrid: aggregates grown over its
//! Type 1 links and the graphs of the levels above ([module
//! docs](super)).

use super::level::Level;
use super::{COARSEST, FIRST, NONE, SIZE};
use crate::sim::connections::Connections;

/// The links the hierarchy is made over: the Type 1 links.
fn links(connections: &Connections) -> impl Iterator<Item = (u32, u32)> + '_ {
    connections.type1().map(|l| (l.a, l.b))
}

/// What a hierarchy depends on: the particle count, the link count and a
/// checksum of their ends.
pub(super) fn key(connections: &Connections, n: usize) -> (usize, usize, u64) {
    let mut sum = 0u64;
    let mut count = 0;
    for (a, b) in links(connections) {
        sum = sum
            .rotate_left(5)
            .wrapping_add(((a as u64) << 32) | b as u64);
        count += 1;
    }
    (n, count, sum)
}

/// The graph of `n` nodes joined by `edges` (ends out of range ignored):
/// each node's neighbours, sorted, without itself.
pub(super) fn graph(n: usize, edges: impl Iterator<Item = (u32, u32)>) -> Vec<Vec<u32>> {
    let mut out = vec![Vec::new(); n];
    for (a, b) in edges {
        if a != b && (a as usize) < n && (b as usize) < n {
            out[a as usize].push(b);
            out[b as usize].push(a);
        }
    }
    for row in &mut out {
        row.sort_unstable();
        row.dedup();
    }
    out
}

/// The hierarchy of a cloth of `n` particles over the links of
/// `connections` (module docs): writes each particle's first-level
/// aggregate into `grouped` and returns the levels, their graphs made and
/// their operators empty.
pub(super) fn hierarchy(connections: &Connections, n: usize, grouped: &mut Vec<u32>) -> Vec<Level> {
    let particles = graph(n, links(connections));
    let count = aggregate(&particles, grouped, FIRST);
    let mut neighbours = lift(&particles, grouped, count);
    let mut levels = Vec::new();
    loop {
        let mut level = Level::new(&neighbours);
        let count = level.count();
        if count <= COARSEST {
            levels.push(level);
            return levels;
        }
        let up = aggregate(&neighbours, &mut level.parent, SIZE);
        if 4 * up > 3 * count {
            // Scraps that no longer aggregate: this level is the last.
            level.parent.clear();
            levels.push(level);
            return levels;
        }
        let above = lift(&neighbours, &level.parent, up);
        let next = Level::new(&above);
        level.lift = (0..count)
            .flat_map(|i| {
                let (start, end) = (level.start[i] as usize, level.start[i + 1] as usize);
                let (parent, next) = (&level.parent, &next);
                level.above[start..end].iter().map(move |&j| {
                    let (p, q) = (parent[i] as usize, parent[j as usize] as usize);
                    if p == q {
                        NONE
                    } else {
                        next.edge(p.min(q), p.max(q)).expect("a lifted edge") as u32
                    }
                })
            })
            .collect();
        levels.push(level);
        neighbours = above;
    }
}

/// The graph of `count` aggregates (`parent` of each node of `nodes`):
/// two are neighbours when nodes of theirs are.
fn lift(nodes: &[Vec<u32>], parent: &[u32], count: usize) -> Vec<Vec<u32>> {
    let edges = nodes
        .iter()
        .enumerate()
        .flat_map(|(i, row)| row.iter().map(move |&j| (parent[i], parent[j as usize])));
    graph(count, edges)
}

/// Groups the nodes of the graph `neighbours` into connected aggregates of
/// about [`SIZE`] (module docs); writes each node's aggregate into `out`
/// and returns how many there are.
pub(super) fn aggregate(neighbours: &[Vec<u32>], out: &mut Vec<u32>, size: usize) -> usize {
    let n = neighbours.len();
    // Seeds in breadth-first order of the whole graph, each piece of it
    // from the node its first node's search reaches last (far from the
    // rest: the levels run across the cloth, not around it, and the
    // coupled aggregates stay close in number).
    let mut order = Vec::with_capacity(n);
    let mut seen = vec![false; n];
    let breadth_first = |root: usize, seen: &mut Vec<bool>, order: &mut Vec<u32>| {
        let from = order.len();
        seen[root] = true;
        order.push(root as u32);
        let mut k = from;
        while k < order.len() {
            let p = order[k] as usize;
            k += 1;
            for &q in &neighbours[p] {
                if !std::mem::replace(&mut seen[q as usize], true) {
                    order.push(q);
                }
            }
        }
        from
    };
    for root in 0..n {
        if seen[root] {
            continue;
        }
        let from = breadth_first(root, &mut seen, &mut order);
        let far = order[order.len() - 1] as usize;
        for &p in &order[from..] {
            seen[p as usize] = false;
        }
        order.truncate(from);
        breadth_first(far, &mut seen, &mut order);
    }
    out.clear();
    out.resize(n, NONE);
    let mut sizes: Vec<usize> = Vec::new();
    let mut ball = Vec::with_capacity(size);
    for &seed in &order {
        if out[seed as usize] != NONE {
            continue;
        }
        let id = sizes.len() as u32;
        ball.clear();
        ball.push(seed);
        out[seed as usize] = id;
        let mut k = 0;
        while k < ball.len() && ball.len() < size {
            let p = ball[k] as usize;
            k += 1;
            for &q in &neighbours[p] {
                if ball.len() < size && out[q as usize] == NONE {
                    out[q as usize] = id;
                    ball.push(q);
                }
            }
        }
        sizes.push(ball.len());
    }
    // A node left alone joins a neighbouring aggregate.
    let mut into: Vec<u32> = (0..sizes.len() as u32).collect();
    for p in 0..n {
        let a = out[p] as usize;
        if sizes[a] == 1
            && let Some(&q) = neighbours[p]
                .iter()
                .find(|&&q| sizes[out[q as usize] as usize] > 1)
        {
            into[a] = out[q as usize];
        }
    }
    // Renumber in order of first appearance.
    let mut number = vec![NONE; sizes.len()];
    let mut count = 0;
    for &p in &order {
        let a = into[out[p as usize] as usize] as usize;
        if number[a] == NONE {
            number[a] = count;
            count += 1;
        }
    }
    for a in out.iter_mut() {
        *a = number[into[*a as usize] as usize];
    }
    count as usize
}
