//! Work on a hand's mask: its holes filled, and the palm, the largest circle inside it
//! (the palm is the hand's widest part: fingers and the wrist are narrower), whose
//! radius is a size of the hand that does not depend on the posture.

/// The mask with its holes filled: every pixel not reachable from the window's border
/// through pixels outside the mask. A hole (a crease the depth step cut, a pixel the
/// sensor lost) is not part of the hand's outline.
pub(crate) fn fill_holes(mask: &[bool], w: usize, h: usize) -> Vec<bool> {
    let mut outside = vec![false; w * h];
    let mut stack: Vec<usize> = Vec::new();
    for x in 0..w {
        stack.push(x);
        stack.push((h.saturating_sub(1)) * w + x);
    }
    for y in 0..h {
        stack.push(y * w);
        stack.push(y * w + w.saturating_sub(1));
    }
    while let Some(i) = stack.pop() {
        if i >= w * h || mask[i] || outside[i] {
            continue;
        }
        outside[i] = true;
        let (x, y) = (i % w, i / w);
        if x > 0 {
            stack.push(i - 1);
        }
        if x + 1 < w {
            stack.push(i + 1);
        }
        if y > 0 {
            stack.push(i - w);
        }
        if y + 1 < h {
            stack.push(i + w);
        }
    }
    outside.iter().map(|&o| !o).collect()
}

/// The chamfer (3-4) distance of each mask pixel to the nearest pixel outside the
/// mask or the window, in pixels.
pub(crate) fn distance_transform(mask: &[bool], w: usize, h: usize) -> Vec<f32> {
    const BIG: f32 = 1e9;
    let mut d: Vec<f32> = mask.iter().map(|&m| if m { BIG } else { 0.0 }).collect();
    let at = |d: &[f32], x: i64, y: i64| {
        if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
            0.0
        } else {
            d[y as usize * w + x as usize]
        }
    };
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            let i = y as usize * w + x as usize;
            if d[i] > 0.0 {
                let m = (at(&d, x - 1, y) + 3.0)
                    .min(at(&d, x, y - 1) + 3.0)
                    .min(at(&d, x - 1, y - 1) + 4.0)
                    .min(at(&d, x + 1, y - 1) + 4.0);
                d[i] = d[i].min(m);
            }
        }
    }
    for y in (0..h as i64).rev() {
        for x in (0..w as i64).rev() {
            let i = y as usize * w + x as usize;
            if d[i] > 0.0 {
                let m = (at(&d, x + 1, y) + 3.0)
                    .min(at(&d, x, y + 1) + 3.0)
                    .min(at(&d, x + 1, y + 1) + 4.0)
                    .min(at(&d, x - 1, y + 1) + 4.0);
                d[i] = d[i].min(m);
            }
        }
    }
    d.iter().map(|v| v / 3.0).collect()
}

/// The centre (window coordinates, pixels) and radius (pixels) of the largest circle
/// in the mask. The centre is the mean of the pixels within a pixel of the deepest,
/// not the first deepest in raster order, which would move with the hand's turn in
/// the image.
pub(crate) fn largest_circle(mask: &[bool], w: usize, h: usize) -> (f32, f32, f32) {
    let dist = distance_transform(mask, w, h);
    let r = dist.iter().copied().fold(0.0f32, f32::max).max(1.0);
    let (mut sx, mut sy, mut n) = (0.0f32, 0.0f32, 0.0f32);
    for (i, &d) in dist.iter().enumerate() {
        if d >= r - 1.0 && mask[i] {
            sx += (i % w) as f32;
            sy += (i / w) as f32;
            n += 1.0;
        }
    }
    (sx / n.max(1.0), sy / n.max(1.0), r)
}
