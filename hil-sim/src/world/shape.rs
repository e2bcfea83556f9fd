//! The primitives a [`super::Room`] is built from, each with an exact ray intersection.

/// A 2D obstacle outline, coordinates in metres in the world frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// A straight wall from `a_m` to `b_m`, visible from both sides.
    Segment {
        /// One end.
        a_m: [f64; 2],
        /// The other end.
        b_m: [f64; 2],
    },
    /// A round pillar.
    Circle {
        /// Centre.
        center_m: [f64; 2],
        /// Radius.
        radius_m: f64,
    },
}

impl Shape {
    /// Distance along the ray from `origin_m` in the unit direction `dir` to the nearest
    /// intersection in front of the origin (strictly positive distance), if any.
    pub fn intersect(&self, origin_m: [f64; 2], dir: [f64; 2]) -> Option<f64> {
        match *self {
            Shape::Segment { a_m, b_m } => intersect_segment(origin_m, dir, a_m, b_m),
            Shape::Circle { center_m, radius_m } => {
                intersect_circle(origin_m, dir, center_m, radius_m)
            }
        }
    }

    /// The four sides of the axis-aligned rectangle with corners `min_m` and `max_m`.
    pub fn rectangle(min_m: [f64; 2], max_m: [f64; 2]) -> [Shape; 4] {
        let [x0, y0] = min_m;
        let [x1, y1] = max_m;
        let corners = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
        [0, 1, 2, 3].map(|i| Shape::Segment {
            a_m: corners[i],
            b_m: corners[(i + 1) % 4],
        })
    }
}

/// Ray/segment intersection by solving `origin + t·dir = a + s·(b − a)` for `t > 0`,
/// `0 ≤ s ≤ 1`. A ray parallel to the segment does not hit it.
fn intersect_segment(origin: [f64; 2], dir: [f64; 2], a: [f64; 2], b: [f64; 2]) -> Option<f64> {
    let edge = [b[0] - a[0], b[1] - a[1]];
    let denom = cross(dir, edge);
    if denom.abs() < 1e-12 {
        return None;
    }
    let to_a = [a[0] - origin[0], a[1] - origin[1]];
    let t = cross(to_a, edge) / denom;
    let s = cross(to_a, dir) / denom;
    (t > 1e-9 && (0.0..=1.0).contains(&s)).then_some(t)
}

/// Ray/circle intersection: the smaller positive root of `|origin + t·dir − c|² = r²`.
fn intersect_circle(origin: [f64; 2], dir: [f64; 2], center: [f64; 2], radius: f64) -> Option<f64> {
    let oc = [origin[0] - center[0], origin[1] - center[1]];
    let b = oc[0] * dir[0] + oc[1] * dir[1];
    let c = oc[0] * oc[0] + oc[1] * oc[1] - radius * radius;
    let disc = b * b - c;
    if disc < 0.0 {
        return None;
    }
    let root = disc.sqrt();
    [-b - root, -b + root].into_iter().find(|&t| t > 1e-9)
}

fn cross(u: [f64; 2], v: [f64; 2]) -> f64 {
    u[0] * v[1] - u[1] * v[0]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_hit_and_miss() {
        let wall = Shape::Segment {
            a_m: [2.0, -1.0],
            b_m: [2.0, 1.0],
        };
        let t = wall.intersect([0.0, 0.0], [1.0, 0.0]).unwrap();
        assert!((t - 2.0).abs() < 1e-12);
        assert_eq!(wall.intersect([0.0, 0.0], [-1.0, 0.0]), None);
        assert_eq!(wall.intersect([0.0, 0.0], [0.0, 1.0]), None);
        assert_eq!(wall.intersect([0.0, 5.0], [1.0, 0.0]), None);
    }

    #[test]
    fn circle_from_outside_and_inside() {
        let pillar = Shape::Circle {
            center_m: [5.0, 0.0],
            radius_m: 1.0,
        };
        let t = pillar.intersect([0.0, 0.0], [1.0, 0.0]).unwrap();
        assert!((t - 4.0).abs() < 1e-12);
        let t = pillar.intersect([5.0, 0.0], [0.0, 1.0]).unwrap();
        assert!((t - 1.0).abs() < 1e-12);
        assert_eq!(pillar.intersect([0.0, 0.0], [0.0, 1.0]), None);
    }
}
