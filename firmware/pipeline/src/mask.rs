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
