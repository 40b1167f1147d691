//! Boolean masks over grids of cells (the FTP's tiles, the thermometer's blocks).

/// `on` (`tw × th` cells) grown by one cell in each of the eight directions: across, then
/// down (a 3 × 3 square is a 3-wide row swept 3 high), branch-free, whatever the number of
/// cells set.
pub fn dilate(on: &[bool], tw: usize, th: usize) -> Vec<bool> {
    let n = tw * th;
    if n == 0 {
        return Vec::new();
    }
    let mut across = vec![false; n];
    for (a, o) in across.chunks_exact_mut(tw).zip(on.chunks_exact(tw)) {
        for x in 0..tw {
            let left = x > 0 && o[x - 1];
            let right = x + 1 < tw && o[x + 1];
            a[x] = o[x] | left | right;
        }
    }
    let mut dil = across.clone();
    for (d, up) in dil[tw..].iter_mut().zip(&across[..n - tw]) {
        *d |= *up;
    }
    for (d, down) in dil[..n - tw].iter_mut().zip(&across[tw..]) {
        *d |= *down;
    }
    dil
}

/// The separate parts of `on` (`tw × th` cells), cells touching across an edge or a corner
/// belonging to one part: each part as a mask of its own, in the order of its first cell
/// (row by row).
pub fn parts(on: &[bool], tw: usize, th: usize) -> Vec<Vec<bool>> {
    let n = (tw * th).min(on.len());
    let mut seen = vec![false; n];
    let mut out = Vec::new();
    for start in 0..n {
        if !on[start] || seen[start] {
            continue;
        }
        let mut part = vec![false; n];
        for i in component(&mut seen, (tw, th), start, |j| on[j]) {
            part[i] = true;
        }
        out.push(part);
    }
    out
}

/// The 8-connected component of `seed` among the cells of a `w × h` grid that are
/// `inside`, as indices in the order they are reached (the seed first), marking each in
/// `seen`; cells already `seen` are not entered. The caller has checked the seed.
pub fn component(
    seen: &mut [bool],
    (w, h): (usize, usize),
    seed: usize,
    inside: impl Fn(usize) -> bool,
) -> Vec<usize> {
    let (mut stack, mut out) = (vec![seed], Vec::new());
    seen[seed] = true;
    while let Some(i) = stack.pop() {
        out.push(i);
        let (x, y) = (i % w, i / w);
        for ny in y.saturating_sub(1)..(y + 2).min(h) {
            for nx in x.saturating_sub(1)..(x + 2).min(w) {
                let j = ny * w + nx;
                if !seen[j] && inside(j) {
                    seen[j] = true;
                    stack.push(j);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(rows: &[&str]) -> (Vec<bool>, usize, usize) {
        let on = rows
            .iter()
            .flat_map(|r| r.bytes().map(|b| b == b'#'))
            .collect();
        (on, rows[0].len(), rows.len())
    }

    #[test]
    fn cells_touching_at_a_corner_are_one_part_and_a_gap_makes_two() {
        let (on, tw, th) = grid(&["##...", ".#..#", "..#.#", "....#"]);
        let parts = parts(&on, tw, th);
        assert_eq!(parts.len(), 2);
        let cells = |p: &[bool]| -> Vec<usize> { (0..p.len()).filter(|&i| p[i]).collect() };
        assert_eq!(cells(&parts[0]), vec![0, 1, 6, 12]);
        assert_eq!(cells(&parts[1]), vec![9, 14, 19]);
        // Every cell set is in exactly one part.
        for (i, &o) in on.iter().enumerate() {
            assert_eq!(parts.iter().filter(|p| p[i]).count(), usize::from(o));
        }
    }

    #[test]
    fn nothing_set_has_no_part() {
        assert!(parts(&[false; 6], 3, 2).is_empty());
        assert!(parts(&[], 0, 0).is_empty());
    }
}
