//! Bringing results back from the GPU: a staging buffer, a copy, a map, a wait.

use anyhow::{Result, anyhow, bail};

use super::GpuContext;

/// A reusable MAP_READ staging buffer.
pub struct Staging {
    pub buffer: wgpu::Buffer,
    pub size: u64,
}

impl Staging {
    pub fn new(device: &wgpu::Device, size: u64, label: &str) -> Self {
        let size = size.max(4).next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT);
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self { buffer, size }
    }

    /// Maps the first `len` bytes (after the submission that filled them), copies them out and
    /// unmaps.
    pub fn read(&self, ctx: &GpuContext, len: u64) -> Result<Vec<u8>> {
        self.read_with(ctx, len, <[u8]>::to_vec)
    }

    /// Maps the first `len` bytes (after the submission that filled them), hands them to `f` in
    /// place and unmaps — for large results (the frame) that `f` converts anyway, so they are not
    /// first copied whole.
    pub fn read_with<T>(&self, ctx: &GpuContext, len: u64, f: impl FnOnce(&[u8]) -> T) -> Result<T> {
        Ok(f(self.map(ctx, len)?.bytes()))
    }

    /// Maps the first `len` bytes (after the submission that filled them) and hands them over
    /// mapped: whoever holds the [`Mapped`] reads them, on any thread, and dropping it unmaps.
    pub fn map(&self, ctx: &GpuContext, len: u64) -> Result<Mapped> {
        let len = len.next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT).min(self.size);
        let (tx, rx) = std::sync::mpsc::channel();
        self.buffer.map_async(wgpu::MapMode::Read, ..len, move |r| {
            let _ = tx.send(r);
        });
        // When the submission that filled the buffer is done already (a frame waited for, with
        // later frames in flight behind it), the map completes at the next poll; waiting for the
        // device instead would wait for every frame submitted since.
        ctx.device.poll(wgpu::PollType::Poll).map_err(|e| anyhow!("waiting for the GPU failed: {e}"))?;
        let mapped = match rx.try_recv() {
            Ok(mapped) => mapped,
            Err(_) => {
                ctx.device
                    .poll(wgpu::PollType::wait_indefinitely())
                    .map_err(|e| anyhow!("waiting for the GPU failed: {e}"))?;
                rx.recv().map_err(|_| anyhow!("the GPU readback was dropped"))?
            }
        };
        mapped.map_err(|e| anyhow!("mapping a GPU buffer for reading failed: {e}"))?;
        let view = match self.buffer.get_mapped_range(..len) {
            Ok(view) => view,
            Err(e) => {
                self.buffer.unmap();
                bail!("{e}");
            }
        };
        Ok(Mapped { view: Some(view), buffer: self.buffer.clone() })
    }
}

/// A staging buffer's bytes, mapped for reading; unmapped when dropped.
pub struct Mapped {
    view: Option<wgpu::BufferView>,
    buffer: wgpu::Buffer,
}

impl Mapped {
    pub fn bytes(&self) -> &[u8] {
        self.view.as_deref().expect("mapped until dropped")
    }
}

impl Drop for Mapped {
    fn drop(&mut self) {
        self.view.take();
        self.buffer.unmap();
    }
}

/// Reads a whole storage buffer (test and diagnostic use: allocates a staging buffer).
pub fn read_buffer(ctx: &GpuContext, src: &wgpu::Buffer) -> Result<Vec<u8>> {
    let staging = Staging::new(&ctx.device, src.size(), "readback");
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    enc.copy_buffer_to_buffer(src, 0, &staging.buffer, 0, src.size());
    ctx.queue.submit([enc.finish()]);
    staging.read(ctx, src.size())
}

/// Reads the `extent` texels at a 3D texture's origin, `bytes_per_texel` each, into tightly
/// packed rows.
pub fn read_texture_3d(ctx: &GpuContext, tex: &wgpu::Texture, extent: glam::UVec3, bytes_per_texel: u32) -> Result<Vec<u8>> {
    let size = wgpu::Extent3d { width: extent.x, height: extent.y, depth_or_array_layers: extent.z };
    let row = size.width * bytes_per_texel;
    let padded = row.next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let total = padded as u64 * size.height as u64 * size.depth_or_array_layers as u64;
    let staging = Staging::new(&ctx.device, total, "texture readback");
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    enc.copy_texture_to_buffer(
        tex.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &staging.buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(size.height),
            },
        },
        size,
    );
    ctx.queue.submit([enc.finish()]);
    let raw = staging.read(ctx, total)?;
    let mut out = Vec::with_capacity((row * size.height * size.depth_or_array_layers) as usize);
    for chunk in raw.chunks(padded as usize) {
        out.extend_from_slice(&chunk[..row as usize]);
    }
    Ok(out)
}
