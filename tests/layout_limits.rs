//! `gbuf layouts --check`'s WebGPU rule against wgpu's own validation: every format's render-target byte cost and
//! alignment equal wgpu-types', and for every multiset of colour-renderable formats up to 8 attachments (in one
//! binding order and its reverse) the colour bytes per sample and the verdict at 32, 64 and 128 bytes equal what
//! wgpu-core's `validate_color_attachment_bytes_per_sample` returns.

use gbuf::layout::limits::{webgpu_byte_cost, webgpu_bytes_per_sample};
use gbuf::layout::Format;
use wgpu_types::TextureFormat as T;

/// The wgpu format of each of gbuf's (`None`: no WebGPU format, the CPU-only `rgb8`).
fn wgpu(f: Format) -> Option<T> {
    use Format::*;
    Some(match f {
        R8 => T::R8Unorm,
        Rg8 => T::Rg8Unorm,
        Rgb8 => return None,
        Rgba8 => T::Rgba8Unorm,
        Rgba8Srgb => T::Rgba8UnormSrgb,
        Rgba8Snorm => T::Rgba8Snorm,
        Rgb10A2 => T::Rgb10a2Unorm,
        R11G11B10F => T::Rg11b10Ufloat,
        Rgb9e5 => T::Rgb9e5Ufloat,
        R16F => T::R16Float,
        Rg16F => T::Rg16Float,
        Rgba16F => T::Rgba16Float,
        R16Unorm => T::R16Unorm,
        Rg16Unorm => T::Rg16Unorm,
        Rg16Snorm => T::Rg16Snorm,
        Rgba16Unorm => T::Rgba16Unorm,
        R16Ui => T::R16Uint,
        R32F => T::R32Float,
        Rg32F => T::Rg32Float,
        Rgba32F => T::Rgba32Float,
        R32Ui => T::R32Uint,
        Rg32Ui => T::Rg32Uint,
        Rgba32Ui => T::Rgba32Uint,
        D16 => T::Depth16Unorm,
        D24S8 => T::Depth24PlusStencil8,
        D32F => T::Depth32Float,
    })
}

#[test]
fn every_formats_byte_cost_and_alignment_are_wgpus() {
    for f in Format::ALL {
        let want = wgpu(f).and_then(|t| Some((t.target_pixel_byte_cost()?, t.target_component_alignment()?)));
        assert_eq!(webgpu_byte_cost(f), want, "{f}");
    }
}

#[test]
fn the_bytes_per_sample_rule_is_wgpu_cores_on_every_multiset_up_to_8_targets() {
    let colour: Vec<Format> = Format::ALL.into_iter().filter(|&f| webgpu_byte_cost(f).is_some()).collect();
    assert!(colour.len() >= 16, "{colour:?}");
    // Every multiset of up to 8, as non-decreasing index sequences.
    let mut checked = 0u64;
    let mut rejected = [0u64; 3];
    let mut stack: Vec<usize> = Vec::new();
    loop {
        if !stack.is_empty() {
            let forward: Vec<Format> = stack.iter().map(|&i| colour[i]).collect();
            let backward: Vec<Format> = forward.iter().rev().copied().collect();
            for formats in [forward, backward] {
                let ours = webgpu_bytes_per_sample(&formats).expect("renderable formats");
                for (k, limit) in [32, 64, 128].into_iter().enumerate() {
                    let theirs = wgpu_core::validation::validate_color_attachment_bytes_per_sample(
                        formats.iter().map(|&f| wgpu(f).unwrap()),
                        limit,
                    );
                    match theirs {
                        Ok(()) => assert!(ours <= limit, "{formats:?}: {ours} > {limit} but wgpu accepts"),
                        Err(wgpu_core::command::ColorAttachmentError::TooManyBytesPerSample { total, .. }) => {
                            assert_eq!(ours, total, "{formats:?}");
                            assert!(ours > limit, "{formats:?}");
                            rejected[k] += 1;
                        }
                        Err(e) => panic!("{formats:?}: {e:?}"),
                    }
                }
                checked += 1;
            }
        }
        // Next multiset: extend while shorter than 8, else advance the last index (dropping those at the end).
        if stack.len() < 8 {
            stack.push(stack.last().copied().unwrap_or(0));
            continue;
        }
        while let Some(last) = stack.pop() {
            if last + 1 < colour.len() {
                stack.push(last + 1);
                break;
            }
        }
        if stack.is_empty() {
            break;
        }
    }
    assert!(checked > 1_000_000, "{checked}");
    // Both rules reject at 32 and 64 bytes; 8 targets of the widest format (16 bytes) are exactly 128.
    assert!(rejected[0] > rejected[1] && rejected[1] > 0 && rejected[2] == 0, "{rejected:?}");
}
