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

/// A device on lavapipe (Mesa's Vulkan on the CPU) with WebGPU's default limits and no optional feature: what every
/// conforming WebGPU device offers at least.
fn lavapipe() -> (wgpu::Device, wgpu::Queue) {
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::VULKAN,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    });
    let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
    let adapter = adapters
        .into_iter()
        .find(|a| a.get_info().device_type == wgpu::DeviceType::Cpu)
        .expect("no CPU Vulkan adapter: install Mesa's lavapipe (Debian: mesa-vulkan-drivers)");
    let desc = wgpu::DeviceDescriptor {
        label: Some("gbuf fit check"),
        required_features: wgpu::Features::empty(),
        required_limits: wgpu::Limits::default(),
        ..Default::default()
    };
    pollster::block_on(adapter.request_device(&desc)).expect("a device with WebGPU's default limits on lavapipe")
}

/// Creates a render pipeline whose targets are `formats` (binding order; a depth format is the depth attachment) at
/// `samples`, draws a triangle into fresh textures of them and submits it. `Err` holds wgpu's validation error.
fn draw(device: &wgpu::Device, queue: &wgpu::Queue, formats: &[Format], samples: u32) -> Result<(), String> {
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let colors: Vec<T> = formats.iter().filter(|f| !f.is_depth()).map(|&f| wgpu(f).unwrap()).collect();
    let depth = formats.iter().find(|f| f.is_depth()).map(|&f| wgpu(f).unwrap());
    let uint = |t: &T| t.sample_type(None, None) == Some(wgpu::TextureSampleType::Uint);
    let mut wgsl = String::from(
        "@vertex fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4f {\n\
         return vec4f(f32(i & 1u) * 4.0 - 1.0, f32(i >> 1u) * 4.0 - 1.0, 0.5, 1.0);\n}\nstruct Out {\n",
    );
    for (k, t) in colors.iter().enumerate() {
        wgsl.push_str(&format!("  @location({k}) c{k}: vec4<{}>,\n", if uint(t) { "u32" } else { "f32" }));
    }
    wgsl.push_str("}\n@fragment fn fs() -> Out {\n  var o: Out;\n");
    for (k, t) in colors.iter().enumerate() {
        wgsl.push_str(&format!("  o.c{k} = vec4<{0}>({0}(1));\n", if uint(t) { "u32" } else { "f32" }));
    }
    wgsl.push_str("  return o;\n}\n");
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: None,
        source: wgpu::ShaderSource::Wgsl(wgsl.into()),
    });
    let targets: Vec<Option<wgpu::ColorTargetState>> = colors
        .iter()
        .map(|&format| Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL }))
        .collect();
    let depth_stencil = depth.map(|format| wgpu::DepthStencilState {
        format,
        depth_write_enabled: Some(true),
        depth_compare: Some(wgpu::CompareFunction::Always),
        stencil: Default::default(),
        bias: Default::default(),
    });
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: None,
        layout: None,
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil,
        multisample: wgpu::MultisampleState { count: samples, ..Default::default() },
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs"),
            compilation_options: Default::default(),
            targets: &targets,
        }),
        multiview_mask: None,
        cache: None,
    });
    let texture = |format: T| {
        device
            .create_texture(&wgpu::TextureDescriptor {
                label: None,
                size: wgpu::Extent3d { width: 16, height: 16, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: samples,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            })
            .create_view(&Default::default())
    };
    let views: Vec<wgpu::TextureView> = colors.iter().map(|&t| texture(t)).collect();
    let depth_view = depth.map(texture);
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let attachments: Vec<Option<wgpu::RenderPassColorAttachment<'_>>> = views
            .iter()
            .map(|view| {
                Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(Default::default()),
                        store: wgpu::StoreOp::Store,
                    },
                })
            })
            .collect();
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: None,
            color_attachments: &attachments,
            depth_stencil_attachment: depth_view.as_ref().map(|view| wgpu::RenderPassDepthStencilAttachment {
                view,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            ..Default::default()
        });
        pass.set_pipeline(&pipeline);
        pass.draw(0..3, 0..1);
    }
    queue.submit([encoder.finish()]);
    device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| e.to_string())?;
    match pollster::block_on(scope.pop()) {
        None => Ok(()),
        Some(e) => Err(e.to_string()),
    }
}

/// `gbuf layouts --check`'s WebGPU verdicts against a real implementation: every built-in layout with a WebGPU
/// format for each target, and the webgpu-samples deferred renderer's targets before and after they fitted, become
/// a render pipeline on lavapipe with WebGPU's default limits (32 colour bytes per sample) at 1× and 4×, and a frame
/// is drawn into them. What the check accepts draws without a validation error; what it rejects (over the byte
/// budget, or a format without guaranteed MSAA) fails wgpu's validation.
#[test]
fn webgpu_verdicts_hold_for_a_draw_on_lavapipe() {
    use gbuf::layout::limits::{check, Platform};
    let (device, queue) = lavapipe();
    let webgpu = Platform::by_name("webgpu").unwrap();
    let mut sets: Vec<(String, Vec<Format>)> = gbuf::layout::Layout::builtins()
        .iter()
        .filter(|l| l.formats().iter().all(|&f| wgpu(f).is_some()))
        .map(|l| (l.name().to_string(), l.formats().to_vec()))
        .collect();
    sets.push(("webgpu-samples before".into(), vec![Format::Rgba32F, Format::Rgba32F, Format::Rgba8]));
    sets.push(("webgpu-samples after".into(), vec![Format::D24S8, Format::Rgba16F, Format::Rgba8]));
    let (mut accepted, mut rejected) = (0, 0);
    for (name, formats) in &sets {
        for samples in [1, 4] {
            let verdict = check(webgpu, formats, samples);
            let drawn = draw(&device, &queue, formats, samples);
            if verdict.fits() {
                accepted += 1;
                assert!(drawn.is_ok(), "{name} at {samples}x: the check accepts it, wgpu refused: {drawn:?}");
            } else if verdict.needs.is_empty() {
                rejected += 1;
                assert!(
                    drawn.is_err(),
                    "{name} at {samples}x: the check rejects it ({:?}), wgpu drew it",
                    verdict.problems
                );
            }
        }
    }
    // The sample holds both kinds, a rejection for bytes alone among them (reference-f32 at 1×: 80 of 32 bytes).
    assert!(accepted >= 8 && rejected >= 3, "{accepted} accepted, {rejected} rejected");
    let reference = &sets.iter().find(|s| s.0 == "reference-f32").unwrap().1;
    let one = check(webgpu, reference, 1);
    assert!(one.problems.iter().all(|p| p.contains("bytes")) && !one.fits());
    let e = draw(&device, &queue, reference, 1).unwrap_err();
    assert!(e.to_lowercase().contains("bytes") || e.contains("ColorAttachmentBytesPerSample"), "{e}");
}
