//! A frame kept small enough to be detected again later, at limits learned afterwards, without
//! decoding it again: the pixels any detection at or above a threshold can read.
//!
//! Why. The detection limits are learned from a sample spread over the whole recording
//! ([`super::learn`]), and a video cannot be read twice for the price of once: every frame
//! would be decoded once for the sample and once more for the detection. A sketch is made in
//! the one pass that reads the frames, and detected from once the limits are known.
//!
//! What a detection reads (module [`super::measure`]). Its background comes from a sparse
//! sample of the whole frame: the sketch keeps the [`Background`] itself. Every other read is
//! within a region's pixels or within its bounding box grown by `⌈window margin⌉ + 1` pixels
//! (the `Refined` window; a split part's window is never larger). The pixels above a threshold
//! `t ≥ s` are a subset of those above `s`, so each region at `t` lies inside one region at `s`,
//! and its grown box inside that region's grown box. The sketch keeps, for every 8-connected
//! region above `s`, its box grown by the margin: the frame rebuilt from those boxes, zero
//! elsewhere (every pixel outside them is at most `s`, so at most `t`), gives every detection
//! at a threshold of at least `s` and a margin of at most the sketch's exactly what the frame
//! gives — the same regions, windows, blobs and errors. A frame with more regions above `s`
//! than the configuration allows is kept whole.

use std::cell::RefCell;
use std::thread::LocalKey;

use super::learn::FrameSample;
use super::{
    Background, DetectConfig, DetectError, GrayView, Intensity, PixelBox, RoundnessChoices,
    Threshold, components, estimate_background,
};
use crate::io::recording::GrayFrame;

/// A frame's background and the boxes of its pixels a detection can read ([module docs](self)).
#[derive(Debug, Clone, PartialEq)]
pub struct Sketch {
    width: usize,
    height: usize,
    background: Background,
    /// Every detection at a threshold at or above this level reads only kept pixels.
    level: u32,
    /// ... when its `Refined` window grows a box by at most this many pixels.
    margin_px: u32,
    boxes: Boxes,
}

/// The kept boxes, each with its pixels row after row.
#[derive(Debug, Clone, PartialEq)]
enum Boxes {
    Eight(Vec<(PixelBox, Vec<u8>)>),
    Sixteen(Vec<(PixelBox, Vec<u16>)>),
}

/// The pixels a configuration's `Refined` window grows a region's box by (and split parts'
/// windows stay within): `⌈margin⌉ + 1`.
pub(crate) fn window_growth_px(cfg: &DetectConfig) -> u32 {
    cfg.window_margin_px.clamp(0.0, 64.0).ceil() as u32 + 1
}

impl Sketch {
    /// `image` sketched for detections with `cfg`'s window margin at any threshold at or above
    /// the lower of its automatic level and `cfg`'s fixed threshold.
    #[must_use]
    pub fn of(image: &GrayFrame, cfg: &DetectConfig) -> Self {
        match image {
            GrayFrame::Eight(i) => sketch_view(GrayView::new(i), cfg, Boxes::Eight),
            GrayFrame::Sixteen(i) => sketch_view(GrayView::new(i), cfg, Boxes::Sixteen),
        }
    }

    /// Bytes kept: the pixels and each box's bookkeeping.
    #[must_use]
    pub fn bytes(&self) -> usize {
        let each = std::mem::size_of::<(PixelBox, Vec<u8>)>();
        match &self.boxes {
            Boxes::Eight(b) => b.iter().map(|(_, p)| each + p.len()).sum(),
            Boxes::Sixteen(b) => b.iter().map(|(_, p)| each + 2 * p.len()).sum(),
        }
    }

    /// What [`super::detect`] gives on the frame with `cfg`.
    ///
    /// # Errors
    /// As [`super::detect`]; [`DetectError::Sketch`] when `cfg` may read pixels the sketch
    /// did not keep.
    pub fn detect(&self, cfg: &DetectConfig) -> Result<Vec<super::Blob>, DetectError> {
        self.check(cfg)?;
        self.with_frame(|frame| match frame {
            Frame::Eight(view) => super::detect_view_with(view, &self.background, cfg),
            Frame::Sixteen(view) => super::detect_view_with(view, &self.background, cfg),
        })
    }

    /// What [`super::detect_choices`] gives on the frame with `cfg`.
    ///
    /// # Errors
    /// As [`Self::detect`].
    pub fn detect_choices(&self, cfg: &DetectConfig) -> Result<RoundnessChoices, DetectError> {
        self.check(cfg)?;
        self.with_frame(|frame| match frame {
            Frame::Eight(view) => super::detect_choices_with(view, &self.background, cfg),
            Frame::Sixteen(view) => super::detect_choices_with(view, &self.background, cfg),
        })
    }

    /// What [`FrameSample::detect`] gives on the frame with `base`.
    ///
    /// # Errors
    /// As [`Self::detect`].
    pub fn sample(&self, base: &DetectConfig) -> Result<FrameSample, DetectError> {
        self.check(&FrameSample::permissive(base))?;
        self.with_frame(|frame| match frame {
            Frame::Eight(view) => FrameSample::detect_with(view, &self.background, base),
            Frame::Sixteen(view) => FrameSample::detect_with(view, &self.background, base),
        })
    }

    /// `Ok` when every pixel a detection with `cfg` reads was kept.
    fn check(&self, cfg: &DetectConfig) -> Result<(), DetectError> {
        let level = match self.boxes {
            Boxes::Eight(_) => cfg.threshold.level::<u8>(&self.background),
            Boxes::Sixteen(_) => cfg.threshold.level::<u16>(&self.background),
        };
        if level >= self.level && window_growth_px(cfg) <= self.margin_px {
            Ok(())
        } else {
            Err(DetectError::Sketch {
                level,
                kept_level: self.level,
            })
        }
    }

    /// Calls `f` on the frame rebuilt from the kept boxes (zero elsewhere), in this thread's
    /// scratch frame, which is zeroed again afterwards.
    fn with_frame<T>(&self, f: impl FnOnce(Frame<'_>) -> T) -> T {
        let (width, height) = (self.width, self.height);
        match &self.boxes {
            Boxes::Eight(boxes) => rebuilt(&SCRATCH_8, width, height, boxes, |view| {
                f(Frame::Eight(view))
            }),
            Boxes::Sixteen(boxes) => rebuilt(&SCRATCH_16, width, height, boxes, |view| {
                f(Frame::Sixteen(view))
            }),
        }
    }
}

/// Calls `f` on the `width × height` frame holding `boxes` on zero, built in this thread's
/// `scratch` and zeroed again afterwards.
fn rebuilt<P: Intensity, T>(
    scratch: &'static LocalKey<RefCell<Vec<P>>>,
    width: usize,
    height: usize,
    boxes: &[(PixelBox, Vec<P>)],
    f: impl FnOnce(GrayView<'_, P>) -> T,
) -> T {
    scratch.with(|scratch| {
        let mut scratch = scratch.borrow_mut();
        let pixels = rebuild(&mut scratch, width, height, boxes);
        let result = f(GrayView {
            width,
            height,
            pixels,
        });
        clear(&mut scratch, width, boxes);
        result
    })
}

/// A rebuilt frame of either depth.
enum Frame<'a> {
    Eight(GrayView<'a, u8>),
    Sixteen(GrayView<'a, u16>),
}

thread_local! {
    /// Each thread's zeroed frame to rebuild 8-bit sketches in.
    static SCRATCH_8: RefCell<Vec<u8>> = const { RefCell::new(Vec::new()) };
    /// Each thread's zeroed frame to rebuild 16-bit sketches in.
    static SCRATCH_16: RefCell<Vec<u16>> = const { RefCell::new(Vec::new()) };
}

/// The sketch of `image`, its boxes kept as `kept` makes them.
fn sketch_view<P: Intensity>(
    image: GrayView<'_, P>,
    cfg: &DetectConfig,
    kept: impl FnOnce(Vec<(PixelBox, Vec<P>)>) -> Boxes,
) -> Sketch {
    let background = estimate_background(image);
    let auto = background.auto_threshold::<P>();
    let level = match cfg.threshold {
        Threshold::Fixed(t) => t.min(auto),
        Threshold::Auto | Threshold::AboveBackground(_) => auto,
    };
    let margin_px = window_growth_px(cfg);
    let (width, height) = (image.width, image.height);
    let boxes = if width == 0 || height == 0 || level >= P::FULL_SCALE {
        Vec::new()
    } else {
        match components::label(image, level, cfg.max_regions) {
            Some(regions) => regions
                .iter()
                .map(|r| {
                    let b = r.bounds;
                    let grown = PixelBox {
                        x_min: b.x_min.saturating_sub(margin_px),
                        y_min: b.y_min.saturating_sub(margin_px),
                        x_max: (b.x_max + margin_px).min(width as u32 - 1),
                        y_max: (b.y_max + margin_px).min(height as u32 - 1),
                    };
                    (grown, copy_box(image, grown))
                })
                .collect(),
            // More regions than allowed: the frame kept whole.
            None => vec![(
                PixelBox {
                    x_min: 0,
                    y_min: 0,
                    x_max: width as u32 - 1,
                    y_max: height as u32 - 1,
                },
                image.pixels.to_vec(),
            )],
        }
    };
    Sketch {
        width,
        height,
        background,
        level,
        margin_px,
        boxes: kept(boxes),
    }
}

/// The pixels of `b`, row after row.
fn copy_box<P: Intensity>(image: GrayView<'_, P>, b: PixelBox) -> Vec<P> {
    let (x0, x1) = (b.x_min as usize, b.x_max as usize);
    let mut pixels = Vec::with_capacity(b.width() as usize * b.height() as usize);
    for y in b.y_min as usize..=b.y_max as usize {
        pixels.extend_from_slice(&image.pixels[y * image.width + x0..=y * image.width + x1]);
    }
    pixels
}

/// `scratch` as a `width × height` frame holding `boxes` on zero.
fn rebuild<'s, P: Intensity>(
    scratch: &'s mut Vec<P>,
    width: usize,
    height: usize,
    boxes: &[(PixelBox, Vec<P>)],
) -> &'s [P] {
    if scratch.len() != width * height {
        scratch.clear();
        scratch.resize(width * height, P::zero());
    }
    for (b, pixels) in boxes {
        let w = b.width() as usize;
        for (row, y) in pixels.chunks_exact(w).zip(b.y_min as usize..) {
            let start = y * width + b.x_min as usize;
            scratch[start..start + w].copy_from_slice(row);
        }
    }
    scratch
}

/// Zeroes `boxes` in `scratch` again.
fn clear<P: Intensity>(scratch: &mut [P], width: usize, boxes: &[(PixelBox, Vec<P>)]) {
    for (b, _) in boxes {
        let w = b.width() as usize;
        for y in b.y_min as usize..=b.y_max as usize {
            let start = y * width + b.x_min as usize;
            scratch[start..start + w].fill(P::zero());
        }
    }
}
