//! The arms teachcam knows by name, each from its maker's published numbers.

use std::f64::consts::FRAC_PI_2;

use super::{Arm, AxisLimit, Maker, OpwParameters, Robot, UrParameters, WristInertia};

/// The names `--robot` accepts, in the order help lists them.
pub const KNOWN_ROBOTS: [&str; 5] = ["irb120", "kr6-r700", "kr6-r900", "ur5e", "ur10e"];

impl Robot {
    /// A robot by the name users type (case and `-`/`_` ignored), `None` for an unknown one.
    #[must_use]
    pub fn by_name(name: &str) -> Option<Self> {
        let key: String = name
            .to_ascii_lowercase()
            .chars()
            .filter(|c| !matches!(c, '-' | '_' | ' '))
            .collect();
        match key.as_str() {
            "irb120" | "irb1203/0.58" => Some(Self::irb120()),
            "kr6r700" | "kr6r700sixx" => Some(Self::kr6_r700()),
            "kr6r900" | "kr6r900sixx" => Some(Self::kr6_r900()),
            "ur5e" => Some(Self::ur5e()),
            "ur10e" => Some(Self::ur10e()),
            _ => None,
        }
    }

    /// The ABB IRB 120-3/0.58, from ABB's product specification (3HAC035960-001): base to
    /// axis 2 290 mm, lower arm 270 mm, forearm offset 70 mm, axis 3 to wrist centre 302 mm,
    /// wrist centre to flange 72 mm, so `tool0` at all joints zero is `(374, 0, 630)` mm with
    /// orientation `[0.70711, 0, 0.70711, 0]`. Working ranges ("Robot motion" table): axis 1
    /// ±165°, axis 2 ±110°, axis 3 −110°..+70°, axis 4 ±160°, axis 5 ±120°, axis 6 ±400°;
    /// maximum speeds 250, 250, 250, 320, 320, 420 °/s; payload 3 kg. ABB's joint convention is OPW's with
    /// axis 3 offset by 90° (zero = forearm horizontal).
    #[must_use]
    pub fn irb120() -> Self {
        Self {
            name: "irb120".into(),
            maker: Maker::Abb,
            arm: Arm::SphericalWrist(OpwParameters {
                a1: 0.0,
                a2: -70.0,
                b: 0.0,
                c1: 290.0,
                c2: 270.0,
                c3: 302.0,
                c4: 72.0,
                offsets: [0.0, 0.0, -FRAC_PI_2, 0.0, 0.0, 0.0],
                sign_corrections: [1.0; 6],
            }),
            limits: [
                AxisLimit::from_degrees(-165.0, 165.0, 250.0),
                AxisLimit::from_degrees(-110.0, 110.0, 250.0),
                AxisLimit::from_degrees(-110.0, 70.0, 250.0),
                AxisLimit::from_degrees(-160.0, 160.0, 320.0),
                AxisLimit::from_degrees(-120.0, 120.0, 320.0),
                AxisLimit::from_degrees(-400.0, 400.0, 420.0),
            ],
            max_payload_kg: Some(3.0),
            // Product specification IRB 120 (3HAC035960-001), "Maximum load and moment of
            // inertia": J5 = m ((Z + 0.072)² + L²) ≤ 0.175 kg·m², J6 = m L² ≤ 0.085 kg·m².
            wrist_inertia: Some(WristInertia {
                axis5_to_flange_mm: 72.0,
                j5_max_kgm2: 0.175,
                j6_max_kgm2: 0.085,
            }),
        }
    }

    /// The KUKA KR 6 R700 sixx (KR AGILUS), from KUKA's specification "KR AGILUS sixx"
    /// (Spez KR AGILUS sixx, dimensions and axis data): A1 to A2 25 mm forward and 400 mm up,
    /// A2 to A3 315 mm, A3 to A4 35 mm, A4 to the wrist root point 365 mm, wrist root point to
    /// the flange 80 mm; so the FLANGE at KUKA's home `{0, −90, 90, 0, 0, 0}` is at
    /// `(470, 0, 750)` mm, parallel to `$ROBROOT`. Ranges A1 ±170°, A2 −190°..+45°,
    /// A3 −120°..+156°, A4 ±185°, A5 ±120°, A6 ±350°; speeds 360, 300, 360, 381, 388,
    /// 615 °/s; maximum payload 6 kg (rated 3 kg). KUKA's conventions: A1, A4 and A6 turn the other way from the right-hand rule
    /// about the base z and the forearm (sign −1), A2 = −90° holds the lower arm vertical
    /// (offset), A3 = 0° lines the forearm up with the lower arm.
    #[must_use]
    pub fn kr6_r700() -> Self {
        Self::kr6("kr6-r700", 315.0, 365.0)
    }

    /// The KUKA KR 6 R900 sixx (KR AGILUS), same specification as [`Robot::kr6_r700`]:
    /// A2 to A3 455 mm, A4 to the wrist root point 420 mm, the rest and the axis data
    /// identical; the FLANGE at home is at `(525, 0, 890)` mm.
    #[must_use]
    pub fn kr6_r900() -> Self {
        Self::kr6("kr6-r900", 455.0, 420.0)
    }

    fn kr6(name: &str, c2: f64, c3: f64) -> Self {
        Self {
            name: name.into(),
            maker: Maker::Kuka,
            arm: Arm::SphericalWrist(OpwParameters {
                a1: 25.0,
                a2: -35.0,
                b: 0.0,
                c1: 400.0,
                c2,
                c3,
                c4: 80.0,
                offsets: [0.0, -FRAC_PI_2, 0.0, 0.0, 0.0, 0.0],
                sign_corrections: [-1.0, 1.0, 1.0, -1.0, 1.0, -1.0],
            }),
            limits: [
                AxisLimit::from_degrees(-170.0, 170.0, 360.0),
                AxisLimit::from_degrees(-190.0, 45.0, 300.0),
                AxisLimit::from_degrees(-120.0, 156.0, 360.0),
                AxisLimit::from_degrees(-185.0, 185.0, 381.0),
                AxisLimit::from_degrees(-120.0, 120.0, 388.0),
                AxisLimit::from_degrees(-350.0, 350.0, 615.0),
            ],
            max_payload_kg: Some(6.0),
            wrist_inertia: None,
        }
    }

    /// The Universal Robots UR5e, from UR's "DH parameters for calculations of kinematics
    /// and dynamics": d1 162.5, a2 −425, a3 −392.2, d4 133.3, d5 99.7, d6 99.6 mm; so the
    /// flange at all joints zero is at `(−817.2, −232.9, 62.8)` mm. UR5e technical
    /// specifications: every joint ±360°, every joint 180 °/s; payload 5 kg.
    #[must_use]
    pub fn ur5e() -> Self {
        Self {
            name: "ur5e".into(),
            maker: Maker::UniversalRobots,
            arm: Arm::Ur(UrParameters {
                d1: 162.5,
                a2: -425.0,
                a3: -392.2,
                d4: 133.3,
                d5: 99.7,
                d6: 99.6,
            }),
            limits: [AxisLimit::from_degrees(-360.0, 360.0, 180.0); 6],
            max_payload_kg: Some(5.0),
            wrist_inertia: None,
        }
    }

    /// The Universal Robots UR10e, same sources as [`Robot::ur5e`]: d1 180.7, a2 −612.7,
    /// a3 −571.55, d4 174.15, d5 119.85, d6 116.55 mm (flange at zero:
    /// `(−1184.25, −290.7, 60.85)` mm); every joint ±360°; base and shoulder 120 °/s, elbow
    /// and wrists 180 °/s; payload 12.5 kg (UR's specification since 2023).
    #[must_use]
    pub fn ur10e() -> Self {
        let slow = AxisLimit::from_degrees(-360.0, 360.0, 120.0);
        let fast = AxisLimit::from_degrees(-360.0, 360.0, 180.0);
        Self {
            name: "ur10e".into(),
            maker: Maker::UniversalRobots,
            arm: Arm::Ur(UrParameters {
                d1: 180.7,
                a2: -612.7,
                a3: -571.55,
                d4: 174.15,
                d5: 119.85,
                d6: 116.55,
            }),
            limits: [slow, slow, fast, fast, fast, fast],
            max_payload_kg: Some(12.5),
            wrist_inertia: None,
        }
    }
}
