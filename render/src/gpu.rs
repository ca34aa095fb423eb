//! The wgpu back end: draws the same display list as the CPU back end, headless, into an
//! offscreen texture and reads it back. On machines without a GPU, Mesa's lavapipe gives a
//! CPU Vulkan device. Circles are exact (a signed-distance test per pixel centre), so both
//! back ends cover the same pixels; blending may differ by one level of rounding.

use crate::error::GpuError;
use crate::scene::{Prim, Rgba, Scene};
use image::RgbImage;

const SHADER: &str = r#"
struct VsIn {
    @location(0) pos: vec2<f32>,
    @location(1) color: vec4<f32>,
    @location(2) circle: vec4<f32>,
};
struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec4<f32>,
    @location(1) circle: vec4<f32>,
};
@vertex fn vs(v: VsIn) -> VsOut {
    var o: VsOut;
    o.clip = vec4<f32>(v.pos, 0.0, 1.0);
    o.color = v.color;
    o.circle = v.circle;
    return o;
}
@fragment fn fs(i: VsOut) -> @location(0) vec4<f32> {
    // circle = (centre x, centre y, outer radius, inner radius) in pixels; z < 0: not a circle.
    if (i.circle.z >= 0.0) {
        let d = i.clip.xy - i.circle.xy;
        let d2 = dot(d, d);
        if (d2 > i.circle.z * i.circle.z || d2 < i.circle.w * i.circle.w) {
            discard;
        }
    }
    return i.color;
}
"#;

/// 2 position + 4 colour + 4 circle floats.
const FLOATS_PER_VERTEX: usize = 10;

/// Draws scenes with wgpu.
pub struct WgpuBackend {
    device: wgpu::Device,
    queue: wgpu::Queue,
    pipeline: wgpu::RenderPipeline,
    adapter_name: String,
    /// Vertex bytes, little-endian f32s, rebuilt per frame.
    vertices: Vec<u8>,
    /// Vertex range and atlas offset of each frame in the current batch.
    ranges: Vec<(std::ops::Range<u32>, [u32; 2])>,
    frame_size: [u32; 2],
    /// Render targets and readback buffers by size, most recently used last.
    targets: Vec<(u32, u32, wgpu::Texture, wgpu::Buffer)>,
    vbuf: Option<wgpu::Buffer>,
}

impl std::fmt::Debug for WgpuBackend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WgpuBackend").field("adapter", &self.adapter_name).finish()
    }
}

impl WgpuBackend {
    /// Opens the first adapter wgpu finds (any kind, including CPU ones).
    pub fn new() -> Result<Self, GpuError> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle());
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: None,
            ..Default::default()
        }))
        .map_err(|e| GpuError::NoAdapter(e.to_string()))?;
        let info = adapter.get_info();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("avacraft-render"),
            required_limits: wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits()),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        let module = device
            .create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("scene"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("scene"),
            bind_group_layouts: &[],
            immediate_size: 0,
        });
        let attributes = [
            wgpu::VertexAttribute { format: wgpu::VertexFormat::Float32x2, offset: 0, shader_location: 0 },
            wgpu::VertexAttribute { format: wgpu::VertexFormat::Float32x4, offset: 8, shader_location: 1 },
            wgpu::VertexAttribute { format: wgpu::VertexFormat::Float32x4, offset: 24, shader_location: 2 },
        ];
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("scene"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: (FLOATS_PER_VERTEX * 4) as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &attributes,
                })],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: wgpu::TextureFormat::Rgba8Unorm,
                    blend: Some(wgpu::BlendState::ALPHA_BLENDING),
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        Ok(Self {
            device,
            queue,
            pipeline,
            adapter_name: format!("{} ({:?})", info.name, info.device_type),
            vertices: Vec::new(),
            ranges: Vec::new(),
            frame_size: [0, 0],
            targets: Vec::new(),
            vbuf: None,
        })
    }

    /// The adapter in use, e.g. "llvmpipe (LLVM 15.0.6, 256 bits) (Cpu)".
    pub fn adapter(&self) -> &str {
        &self.adapter_name
    }

    pub fn render(&mut self, scene: &Scene) -> Result<RgbImage, GpuError> {
        let mut v = self.render_batch(std::slice::from_ref(scene))?;
        v.pop().ok_or_else(|| GpuError::Readback("no frame".into()))
    }

    /// Renders many frames of one size in a single submission (an atlas), which is what
    /// makes small MARL frames cheap on a GPU: one round trip instead of one per frame.
    pub fn render_batch(&mut self, scenes: &[Scene]) -> Result<Vec<RgbImage>, GpuError> {
        let Some(first) = scenes.first() else { return Ok(Vec::new()) };
        let (fw, fh) = (first.width, first.height);
        if scenes.iter().any(|s| (s.width, s.height) != (fw, fh)) {
            return scenes.iter().map(|s| self.render(s)).collect();
        }
        let limits = self.device.limits();
        let (max, max_bytes) = (limits.max_texture_dimension_2d, limits.max_buffer_size.min(256 << 20));
        let row_bytes = |w: u32| ((w as u64 * 4).div_ceil(256) * 256).max(256);
        if fw == 0 || fh == 0 || fw > max || fh > max || row_bytes(fw) * fh as u64 > max_bytes {
            return Err(GpuError::Size { w: fw, h: fh, max, bytes: max_bytes });
        }
        // As many frames per row as the texture allows, as many rows as the readback buffer does.
        let cols = ((max / fw) as usize).clamp(1, 64).min(scenes.len());
        let max_rows = ((max / fh) as u64).min(max_bytes / (row_bytes(fw * cols as u32) * fh as u64)).max(1) as usize;
        if scenes.len() > cols * max_rows {
            let mut out = Vec::with_capacity(scenes.len());
            for chunk in scenes.chunks(cols * max_rows) {
                out.extend(self.render_batch(chunk)?);
            }
            return Ok(out);
        }
        let rows = scenes.len().div_ceil(cols);
        let (w, h) = (fw * cols as u32, fh * rows as u32);
        self.vertices.clear();
        self.ranges.clear();
        self.frame_size = [fw, fh];
        let single = scenes.len() == 1;
        let stride = (FLOATS_PER_VERTEX * 4) as u32;
        for (i, scene) in scenes.iter().enumerate() {
            let off = [(i % cols) as u32 * fw, (i / cols) as u32 * fh];
            let start = self.vertices.len() as u32 / stride;
            tessellate(scene, Xf { size: [w as f32, h as f32], off: [off[0] as f32, off[1] as f32] }, !single, &mut self.vertices);
            self.ranges.push((start..self.vertices.len() as u32 / stride, off));
        }
        let clear = if single { first.background } else { Rgba::rgb(0, 0, 0) };
        let atlas = self.draw_target(w, h, clear)?;
        if single {
            return Ok(vec![atlas]);
        }
        let mut out = Vec::with_capacity(scenes.len());
        for i in 0..scenes.len() {
            let (ox, oy) = ((i % cols) as u32 * fw, (i / cols) as u32 * fh);
            out.push(image::imageops::crop_imm(&atlas, ox, oy, fw, fh).to_image());
        }
        Ok(out)
    }

    /// Draws the prepared vertices into a `w` x `h` target and reads it back.
    fn draw_target(&mut self, w: u32, h: u32, clear: Rgba) -> Result<RgbImage, GpuError> {
        let padded = (w * 4).div_ceil(256) * 256;
        if let Some(i) = self.targets.iter().position(|t| t.0 == w && t.1 == h) {
            let t = self.targets.remove(i);
            self.targets.push(t);
        } else {
            let texture = self.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("frame"),
                size: wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba8Unorm,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            });
            let readback = self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("readback"),
                size: padded as u64 * h as u64,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            });
            if self.targets.len() >= 4 {
                self.targets.remove(0);
            }
            self.targets.push((w, h, texture, readback));
        }
        let bytes = &self.vertices;
        let need = (bytes.len() as u64).max(4);
        if self.vbuf.as_ref().is_none_or(|b| b.size() < need) {
            self.vbuf = Some(self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("vertices"),
                size: need.next_power_of_two(),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        let (Some((_, _, texture, readback)), Some(vbuf)) = (self.targets.last(), &self.vbuf) else {
            return Err(GpuError::Readback("buffers missing".into()));
        };
        if !bytes.is_empty() {
            self.queue.write_buffer(vbuf, 0, bytes);
        }
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        let mut encoder = self.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("scene"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color {
                            r: clear.0[0] as f64 / 255.0,
                            g: clear.0[1] as f64 / 255.0,
                            b: clear.0[2] as f64 / 255.0,
                            a: 1.0,
                        }),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            if !bytes.is_empty() {
                pass.set_pipeline(&self.pipeline);
                pass.set_vertex_buffer(0, vbuf.slice(..bytes.len() as u64));
                // Each frame clipped to its own cell of the atlas: nothing bleeds across.
                for (range, off) in &self.ranges {
                    pass.set_scissor_rect(off[0], off[1], self.frame_size[0], self.frame_size[1]);
                    pass.draw(range.clone(), 0..1);
                }
            }
        }
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo { texture, mip_level: 0, origin: wgpu::Origin3d::ZERO, aspect: wgpu::TextureAspect::All },
            wgpu::TexelCopyBufferInfo {
                buffer: readback,
                layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded), rows_per_image: Some(h) },
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
        let index = self.queue.submit([encoder.finish()]);
        readback.map_async(wgpu::MapMode::Read, .., |_| {});
        self.device
            .poll(wgpu::PollType::Wait { submission_index: Some(index), timeout: None })
            .map_err(|e| GpuError::Readback(e.to_string()))?;
        let mut img = RgbImage::new(w, h);
        {
            let data = readback.get_mapped_range(..).map_err(|e| GpuError::Readback(e.to_string()))?;
            for (y, row) in img.as_mut().chunks_exact_mut(w as usize * 3).enumerate() {
                let src = &data[y * padded as usize..y * padded as usize + w as usize * 4];
                for (d, s) in row.chunks_exact_mut(3).zip(src.chunks_exact(4)) {
                    d.copy_from_slice(&s[..3]);
                }
            }
        }
        readback.unmap();
        Ok(img)
    }
}

const NO_CIRCLE: [f32; 4] = [0.0, 0.0, -1.0, 0.0];

/// Where a frame sits in the render target: the target's size and the frame's offset.
#[derive(Clone, Copy)]
struct Xf {
    size: [f32; 2],
    off: [f32; 2],
}

/// Appends one triangle: frame pixels to clip space, colour, circle test.
fn tri(out: &mut Vec<u8>, xf: Xf, pts: [[f32; 2]; 3], c: Rgba, circle: [f32; 4]) {
    let col = [c.0[0] as f32 / 255.0, c.0[1] as f32 / 255.0, c.0[2] as f32 / 255.0, c.0[3] as f32 / 255.0];
    let circle = if circle[2] >= 0.0 { [circle[0] + xf.off[0], circle[1] + xf.off[1], circle[2], circle[3]] } else { circle };
    for p in pts {
        let (x, y) = (p[0] + xf.off[0], p[1] + xf.off[1]);
        let xy = [x / xf.size[0] * 2.0 - 1.0, 1.0 - y / xf.size[1] * 2.0];
        for v in xy.iter().chain(&col).chain(&circle) {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
}

fn quad(out: &mut Vec<u8>, xf: Xf, r: [f32; 4], c: Rgba, circle: [f32; 4]) {
    tri(out, xf, [[r[0], r[1]], [r[2], r[1]], [r[2], r[3]]], c, circle);
    tri(out, xf, [[r[0], r[1]], [r[2], r[3]], [r[0], r[3]]], c, circle);
}

/// Triangles for every primitive, in order.
fn tessellate(scene: &Scene, xf: Xf, background: bool, out: &mut Vec<u8>) {
    let size = xf;
    let quad = |out: &mut Vec<u8>, r: [f32; 4], c: Rgba, circle: [f32; 4]| quad(out, xf, r, c, circle);
    if background {
        // Frames sharing a target each get their own background.
        quad(out, [0.0, 0.0, scene.width as f32, scene.height as f32], scene.background, NO_CIRCLE);
    }
    for p in &scene.prims {
        match p {
            Prim::Cells { rect, .. } if rect[2] <= rect[0] || rect[3] <= rect[1] => {}
            Prim::Ring { r, width, .. } if r + width * 0.5 < 0.0 => {}
            Prim::Cells { rect, cols, rows, colors } => {
                let (cw, ch) = ((rect[2] - rect[0]) / *cols as f32, (rect[3] - rect[1]) / *rows as f32);
                // One quad per horizontal run of equal cells: terrain and fog rows are long runs.
                for cy in 0..*rows {
                    let row = &colors[(cy * cols) as usize..((cy + 1) * cols) as usize];
                    let mut cx = 0;
                    while cx < row.len() {
                        let c = row[cx];
                        let mut end = cx + 1;
                        while end < row.len() && row[end] == c {
                            end += 1;
                        }
                        if c.0[3] != 0 {
                            let y0 = rect[1] + cy as f32 * ch;
                            quad(out, [rect[0] + cx as f32 * cw, y0, rect[0] + end as f32 * cw, y0 + ch], c, NO_CIRCLE);
                        }
                        cx = end;
                    }
                }
            }
            Prim::Rect { rect, color } => {
                if rect[2] > rect[0] && rect[3] > rect[1] {
                    quad(out, *rect, *color, NO_CIRCLE);
                }
            }
            Prim::Disc { c, r, color } => {
                quad(out, [c[0] - r - 1.0, c[1] - r - 1.0, c[0] + r + 1.0, c[1] + r + 1.0], *color, [c[0], c[1], *r, 0.0])
            }
            Prim::Ring { c, r, width, color } => {
                let (ri, ro) = ((r - width * 0.5).max(0.0), r + width * 0.5);
                quad(out, [c[0] - ro - 1.0, c[1] - ro - 1.0, c[0] + ro + 1.0, c[1] + ro + 1.0], *color, [c[0], c[1], ro, ri]);
            }
            Prim::Polygon { points, color } => {
                for k in 1..points.len().saturating_sub(1) {
                    tri(out, size, [points[0], points[k], points[k + 1]], *color, NO_CIRCLE);
                }
            }
            Prim::Line { a, b, width, color } => {
                if let Some(q) = crate::scene::line_quad(*a, *b, *width) {
                    tri(out, size, [q[0], q[1], q[2]], *color, NO_CIRCLE);
                    tri(out, size, [q[0], q[2], q[3]], *color, NO_CIRCLE);
                }
            }
            Prim::Text { pos, scale, text, color } => crate::font::runs(*pos, *scale, text, |r| quad(out, r, *color, NO_CIRCLE)),
        }
    }
}
