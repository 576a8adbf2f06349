//! The smallest circle enclosing a set of points: the paper's "SmallestCircle" blob centre.
//!
//! Welzl's algorithm (*Smallest enclosing disks*, 1991) in its incremental form: keep the
//! smallest circle of the points seen so far; a new point outside it lies on the boundary of
//! the next one, which is found again with that point fixed (and then two points fixed). The
//! answer is unique whatever the order; visiting the points in a scrambled order keeps the
//! expected time linear. For a blob, the run endpoints suffice: every other pixel centre lies
//! on a segment between two of them, inside any circle that holds both.

use crate::geometry::Pixel;

/// A point lies inside a circle when its distance exceeds the radius by at most this, pixels
/// (rounding of the circumcentre of pixel-centre triples).
const INSIDE_TOLERANCE_PX: f64 = 1e-9;

/// A circle in the image, pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle {
    /// Centre, pixels.
    pub center: Pixel,
    /// Radius, pixels.
    pub radius_px: f64,
}

impl Circle {
    fn contains(&self, p: &Pixel) -> bool {
        let (dx, dy) = (p.x - self.center.x, p.y - self.center.y);
        let reach = self.radius_px + INSIDE_TOLERANCE_PX;
        dx * dx + dy * dy <= reach * reach
    }

    fn through_two(a: &Pixel, b: &Pixel) -> Self {
        let center = Pixel::new(0.5 * (a.x + b.x), 0.5 * (a.y + b.y));
        Self {
            center,
            radius_px: 0.5
                * (a.x - b.x)
                    .mul_add(a.x - b.x, (a.y - b.y) * (a.y - b.y))
                    .sqrt(),
        }
    }

    /// The circle through three points; for (nearly) collinear points, the circle on the
    /// two farthest apart.
    fn through_three(a: &Pixel, b: &Pixel, c: &Pixel) -> Self {
        let (bx, by) = (b.x - a.x, b.y - a.y);
        let (cx, cy) = (c.x - a.x, c.y - a.y);
        let d = 2.0 * (bx * cy - by * cx);
        let scale = (bx * bx + by * by).max(cx * cx + cy * cy);
        if d.abs() <= 1e-12 * scale {
            let candidates = [
                Self::through_two(a, b),
                Self::through_two(a, c),
                Self::through_two(b, c),
            ];
            return candidates.into_iter().fold(candidates[0], |best, c| {
                if c.radius_px > best.radius_px {
                    c
                } else {
                    best
                }
            });
        }
        let b2 = bx * bx + by * by;
        let c2 = cx * cx + cy * cy;
        let ux = (cy * b2 - by * c2) / d;
        let uy = (bx * c2 - cx * b2) / d;
        Self {
            center: Pixel::new(a.x + ux, a.y + uy),
            radius_px: ux.mul_add(ux, uy * uy).sqrt(),
        }
    }
}

/// The smallest circle holding every point; `None` for no points.
#[must_use]
pub fn smallest_enclosing_circle(points: &[Pixel]) -> Option<Circle> {
    let n = points.len();
    let first = points.first()?;
    // A fixed scramble of the order: i ↦ i·s mod n with s coprime to n.
    let mut stride = (n as f64 * 0.618_033_988_749_895) as usize | 1;
    while gcd(stride, n) != 1 {
        stride += 2;
    }
    let ordered: Vec<Pixel> = (0..n).map(|i| points[(i * stride) % n]).collect();

    let mut circle = Circle {
        center: *first,
        radius_px: 0.0,
    };
    circle.center = ordered[0];
    for i in 1..n {
        if circle.contains(&ordered[i]) {
            continue;
        }
        // ordered[i] is on the boundary of the circle of ordered[..=i].
        circle = Circle {
            center: ordered[i],
            radius_px: 0.0,
        };
        for j in 0..i {
            if circle.contains(&ordered[j]) {
                continue;
            }
            circle = Circle::through_two(&ordered[i], &ordered[j]);
            for k in 0..j {
                if !circle.contains(&ordered[k]) {
                    circle = Circle::through_three(&ordered[i], &ordered[j], &ordered[k]);
                }
            }
        }
    }
    Some(circle)
}

fn gcd(mut a: usize, mut b: usize) -> usize {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn known_circles() {
        let square = [
            Pixel::new(0.0, 0.0),
            Pixel::new(2.0, 0.0),
            Pixel::new(2.0, 2.0),
            Pixel::new(0.0, 2.0),
            Pixel::new(1.0, 1.0),
        ];
        let c = smallest_enclosing_circle(&square).unwrap();
        assert!((c.center.x - 1.0).abs() < 1e-12 && (c.center.y - 1.0).abs() < 1e-12);
        assert!((c.radius_px - 2f64.sqrt()).abs() < 1e-12);
        // An obtuse triangle: the circle on its longest side.
        let obtuse = [
            Pixel::new(0.0, 0.0),
            Pixel::new(10.0, 0.0),
            Pixel::new(5.0, 1.0),
        ];
        let c = smallest_enclosing_circle(&obtuse).unwrap();
        assert!((c.center.x - 5.0).abs() < 1e-12 && c.center.y.abs() < 1e-12);
        assert!((c.radius_px - 5.0).abs() < 1e-12);
        let collinear = [
            Pixel::new(0.0, 0.0),
            Pixel::new(3.0, 0.0),
            Pixel::new(1.0, 0.0),
        ];
        let c = smallest_enclosing_circle(&collinear).unwrap();
        assert!((c.radius_px - 1.5).abs() < 1e-12);
        assert!(smallest_enclosing_circle(&[]).is_none());
    }

    proptest! {
        /// The circle holds every point and cannot shrink: at least two points lie on it, and
        /// when exactly two do they are diametrically opposite; when three or more do, they do
        /// not all fit in an open half of it (the optimality condition).
        #[test]
        fn holds_all_points_and_is_minimal(
            raw in proptest::collection::vec((-50i32..50, -50i32..50), 2..60)
        ) {
            let points: Vec<Pixel> =
                raw.iter().map(|&(x, y)| Pixel::new(f64::from(x), f64::from(y))).collect();
            let c = smallest_enclosing_circle(&points).unwrap();
            for p in &points {
                prop_assert!(c.center.distance(p) <= c.radius_px + 1e-7);
            }
            if c.radius_px == 0.0 {
                return Ok(());
            }
            let on: Vec<f64> = points
                .iter()
                .filter(|p| (c.center.distance(p) - c.radius_px).abs() < 1e-7)
                .map(|p| (p.y - c.center.y).atan2(p.x - c.center.x))
                .collect();
            prop_assert!(on.len() >= 2);
            // Largest angular gap between boundary points must be at most π.
            let mut angles = on.clone();
            angles.sort_by(f64::total_cmp);
            let mut largest_gap: f64 = angles[0] + std::f64::consts::TAU - angles[angles.len() - 1];
            for w in angles.windows(2) {
                largest_gap = largest_gap.max(w[1] - w[0]);
            }
            prop_assert!(largest_gap <= std::f64::consts::PI + 1e-6);
        }
    }
}
