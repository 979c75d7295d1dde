# Type stubs of the roofgs module (python/src/), installed next to it so that editors and type
# checkers complete its functions. Shapes are [rows, columns]; images are top row first.
# Arguments: a value of the wrong type raises TypeError, one outside the argument's rule (a size of 0, a number that
# is not finite, a negative cuda_device) ValueError, both before any work and in the words
# "audit(): threshold must be a finite number in -1000..1000, got nan"; what the library refuses is roofgs.Error.
import os
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

__version__: str
built_with_cuda: bool  # the module has the CUDA renderer
has_cuda: bool  # ... and a CUDA device answered when it was imported


def cuda_status() -> Dict[str, Any]:
    """built_with_cuda, available (a CUDA device answers now) and reason (CUDA's own words when not)."""

_Path = Union[str, "os.PathLike[str]"]
_Matrix = Union[np.ndarray, Sequence[Sequence[float]]]


class Error(RuntimeError):
    """A RoofGS operation failed. code: the StatusCode number; code_name: e.g. "kIoError"; message."""
    code: int
    code_name: str
    message: str


class Camera:
    """Pinhole camera in the COLMAP frame (x right, y down, z forward); see project() for pixel centres."""
    rotation: np.ndarray  # world-to-camera R, [3, 3] float32
    translation: List[float]  # world-to-camera t, [3]
    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    near_plane: float
    name: str
    def project(self, point: Sequence[float]) -> Tuple[float, float, float]: ...
    def resized(self, width: int, height: int) -> "Camera": ...


def camera_from_inria(rotation_c2w: _Matrix, position: Sequence[float], fx: float, fy: float, width: int,
                      height: int, near_plane: float = 0.2, name: str = "") -> Camera: ...
def camera_from_colmap(qvec: Sequence[float], tvec: Sequence[float], fx: float, fy: float, cx: float, cy: float,
                       width: int, height: int, near_plane: float = 0.2, name: str = "") -> Camera: ...
def camera_from_opencv(K: _Matrix, R: _Matrix, t: Sequence[float], width: int, height: int,
                       near_plane: float = 0.2, name: str = "") -> Camera: ...
def camera_from_opengl(view: _Matrix, projection: _Matrix, width: int, height: int, near_plane: float = 0.2,
                       name: str = "") -> Camera: ...
def camera_from_vulkan(view: _Matrix, projection: _Matrix, width: int, height: int, near_plane: float = 0.2,
                       name: str = "") -> Camera: ...
def load_cameras(path: _Path) -> List[Camera]: ...


class DeviceImage:
    """A rendered plane in GPU memory: colour [H, W, 4] or depth [H, W]; DLPack, NumPy's __array__."""
    shape: List[int]
    dtype: str  # "float32", "float16" or "uint8"
    device: str
    data_ptr: int
    def __dlpack__(self, stream: Optional[int] = None, **kwargs: Any) -> Any: ...
    def __dlpack_device__(self) -> Tuple[int, int]: ...
    def __array__(self, *args: Any, **kwargs: Any) -> np.ndarray: ...
    def synchronize(self) -> None:
        """Wait until the render that writes this plane has finished; numpy() and __array__ wait by themselves."""
    def numpy(self) -> np.ndarray: ...


_Image = Union[np.ndarray, DeviceImage]


# A NumPy array or anything np.asarray takes (a CPU torch tensor); where the signature says so, also a CUDA array:
# a torch CUDA tensor (any float dtype and layout: torch makes it float32 and contiguous on its device), or any
# DLPack producer's float32 C-contiguous CUDA array. CUDA arrays are read on their device, never copied to the
# host (unless device="cpu").
_Array = Any


class Scene:
    """A loaded scene (immutable; share it freely)."""
    info: Dict[str, Any]  # ... and info["lod"]: active, chunks, levels, stored_gaussians, the budgets, pool_bytes
    frame_stats: Optional[Dict[str, Any]]
    """Counts of the last frame render() drew of this scene, None before the first: gaussians, pairs,
    tile_groups, and lod (zeros unless info["lod"]["active"]): splats (Gaussians drawn), chunks_drawn,
    chunks_culled, chunks_coarsened (coarser than pixel_error, for splat_budget), chunks_not_resident (CUDA: drawn
    coarser while the wanted level streams in), ranges_streamed, bytes_streamed (CUDA: requested this frame),
    bytes_resident (bytes of the levels held)."""
    @staticmethod
    def from_arrays(means: _Array, quats: _Array, scales: _Array, opacities: _Array, sh: _Array, *,
                    device: str = "auto", sanitize: bool = False, name: str = "arrays") -> "Scene":
        """means [N, 3], quats [N, 4] (w, x, y, z), scales [N, 3] linear, opacities [N] in [0, 1], sh [N, K, 3]
        (K = 1, 4, 9, 16), float32; a file's value rules (roofgs.Error kInvalidArgument / kCorruptData;
        sanitize=True drops what they reject). CUDA arrays (all five on one device) are checked and copied on
        that device into a CUDA scene there."""
    def arrays(self) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """A CPU scene's Gaussians as from_arrays takes them: (means, quats, scales, opacities, sh), float32
        copies; roofgs.Error for a CUDA scene."""
    device: str  # "cpu" or "cuda"
    def __len__(self) -> int: ...
    # A ring around the scene's content (robust to floaters), as rgs-render --orbit places it.
    def orbit_cameras(self, count: int, width: int = 1920, height: int = 1080) -> List[Camera]: ...
    def render(self, camera: Camera, preset: str = "fastest", width: Optional[int] = None,
               height: Optional[int] = None, background: Sequence[float] = (0.0, 0.0, 0.0),
               format: str = "rgba32f", depth: bool = False,
               stream: Optional[int] = None,
               scratch_budget: int = 0, settle: bool = False) -> Union[_Image, Tuple[_Image, _Image]]: ...


def load(path: _Path, device: str = "auto", presets: Sequence[str] = ("fastest",),
         quantize_other_formats: bool = True, cuda_device: int = 0, spz_frame: Union[str, Mapping[Union[str, os.PathLike], str]] = "rub", *, lod: bool = True,
         splat_budget: int = 3000000, pixel_error: float = 1.5, memory_budget: int = 0,
         stream_bytes: int = 33554432, antialiased: bool = False) -> Scene:
    """A scene in any format on device "cuda", "cpu" or "auto". A level-of-detail .rgs (docs/LOD.md) with
    lod=True draws each frame's selection of levels: at most splat_budget Gaussians (0: no limit), levels whose
    projected error is at most pixel_error pixels where the budget allows; on CUDA streamed into memory_budget
    bytes of device memory (0: a pool that holds every level), reading and uploading at most stream_bytes a frame
    (> 0: the bound on how long a frame waits for the file; levels that do not fit come in later frames), on the
    CPU with every level in host memory.
    lod=False draws its full detail. Other files ignore these (info["notes"] says so for non-default values).
    antialiased=True: trained with the 2D Mip filter, for formats that cannot say so (info["antialiased"])."""
def convert(src: Union[_Path, Sequence[_Path]], dst: _Path, *, to: Optional[str] = None, sh_degree: Optional[int] = None,
            scale_encoding: Optional[str] = None, sh_clip_percentile: Optional[float] = None,
            sh_dc_bits: Optional[int] = None, zstd: Optional[Sequence[str]] = None, profile: Optional[str] = None,
            position_error: Optional[float] = None, target_psnr: Optional[float] = None,
            target_bytes: Optional[int] = None, cameras: Optional[_Path] = None, every: Optional[int] = None,
            limit: Optional[int] = None, orbit: Optional[int] = None, path: Optional[int] = None,
            fly: Optional[int] = None, width: Optional[int] = None, height: Optional[int] = None,
            zstd_level: Optional[int] = None, sanitize: bool = False, allow_empty: bool = False,
            lod: Optional[int] = None, lod_levels: Union[str, int, None] = None, lod_chunk: Optional[int] = None,
            memory_limit: Optional[int] = None, max_gaussians: Optional[int] = None,
            max_decompression_ratio: Optional[int] = None,
            spz_frame: Optional[Union[str, Mapping[Union[str, os.PathLike], str]]] = None,
            antialiased: bool = False, edits: Optional[Sequence[Tuple[str, str]]] = None,
            input_edits: Optional[Sequence[Optional[Sequence[Tuple[str, str]]]]] = None) -> Dict[str, Any]:
    """Every option of rgs-convert, by the snake_case of its long option (None: the tool's default), but the edits
    (--translate, --rotate, --scale, --filter-nan, --filter, --crop-box, --crop-sphere, -outside forms, --decimate),
    which act in the order given and so are one list, `edits`: (name, value) pairs in rgs-convert's spelling, e.g.
    [("rotate", "0,0,90"), ("filter", "opacity gt 0.1"), ("decimate", "0.5")] (README, editing on the way).
    src: a path, or a list or tuple of paths whose scenes are merged into one before the edits (highest SH degree,
    missing bands zero; differing anti-aliasing flags raise roofgs.Error kInvalidArgument naming both files).
    A value outside an option's range raises ValueError saying the rule (lod_chunk without lod_levels too, as
    rgs-convert refuses it), a value of the wrong type TypeError. memory_limit is in bytes (0: half the
    physical memory); an input whose estimated peak memory is above it raises kLimitExceeded before it is read."""
def save(path: _Path, means: _Array, quats: _Array, scales: _Array, opacities: _Array, sh: _Array, *,
         to: Optional[str] = None, sh_degree: Optional[int] = None, scale_encoding: Optional[str] = None,
         sh_clip_percentile: Optional[float] = None, sh_dc_bits: Optional[int] = None,
         zstd: Optional[Sequence[str]] = None, profile: Optional[str] = None, position_error: Optional[float] = None,
         target_psnr: Optional[float] = None, target_bytes: Optional[int] = None, cameras: Optional[_Path] = None,
         every: Optional[int] = None, limit: Optional[int] = None, orbit: Optional[int] = None,
         camera_path: Optional[int] = None, fly: Optional[int] = None, width: Optional[int] = None,
         height: Optional[int] = None, zstd_level: Optional[int] = None, sanitize: bool = False,
         allow_empty: bool = False, lod: Optional[int] = None, lod_levels: Union[str, int, None] = None,
         lod_chunk: Optional[int] = None, memory_limit: Optional[int] = None, max_gaussians: Optional[int] = None,
         max_decompression_ratio: Optional[int] = None, spz_frame: Optional[Union[str, Mapping[Union[str, os.PathLike], str]]] = None,
         antialiased: bool = False, edits: Optional[Sequence[Tuple[str, str]]] = None) -> Dict[str, Any]:
    """convert()'s options; rgs-convert's --path (a camera path of N views) is camera_path here. The arrays are
    already in memory: memory_limit is accepted and not checked."""
def rasterization(means: _Array, quats: _Array, scales: _Array, opacities: _Array, colors: _Array,
                  viewmats: _Array, Ks: _Array, width: int, height: int, near_plane: float = 0.01,
                  far_plane: float = 1e10, radius_clip: float = 0.0, eps2d: float = 0.3,
                  sh_degree: Optional[int] = None, packed: bool = True, tile_size: int = 16,
                  backgrounds: Optional[_Array] = None, render_mode: str = "RGB", sparse_grad: bool = False,
                  absgrad: bool = False, rasterize_mode: str = "classic", channel_chunk: int = 32,
                  distributed: bool = False, camera_model: str = "pinhole", segmented: bool = False,
                  covars: Optional[_Array] = None, with_ut: bool = False, with_eval3d: bool = False,
                  radial_coeffs: Optional[_Array] = None, tangential_coeffs: Optional[_Array] = None,
                  thin_prism_coeffs: Optional[_Array] = None, ftheta_coeffs: Any = None, rolling_shutter: Any = None,
                  viewmats_rs: Optional[_Array] = None, *, preset: str = "fastest", device: str = "auto",
                  cache: bool = True) -> Tuple[Any, Any, Dict[str, Any]]:
    """gsplat's rasterization() for inference, with gsplat's signature (docs/EMBEDDING.md).

    means [..., N, 3], quats [..., N, 4] (w, x, y, z), scales [..., N, 3] linear, opacities [..., N] in
    [0, 1]; colors [..., N, K, 3] SH with sh_degree given (K = 1, 4, 9, 16; min(sh_degree, degree of K) is
    rendered), else [..., N, 3] RGB. viewmats [..., C, 4, 4] world-to-camera (OpenCV axes), Ks [..., C, 3, 3]
    (pixel centres at half-integers), backgrounds [..., C, 3]; render_mode RGB, D, ED, RGB+D or RGB+ED.
    Leading batch dimensions (the same on every array) are rendered element by element and kept on the outputs.

    Returns (colors [..., C, H, W, 3] (+1 depth channel; 1 for D or ED alone), alphas [..., C, H, W, 1], meta)
    as float32 arrays of the caller's type: NumPy for NumPy, torch CPU tensors for torch CPU tensors; for CUDA
    arrays (the five Gaussian arrays on one device; mixing host and CUDA arrays raises ValueError), torch CUDA
    tensors on that device, computed on the device and written on torch's current stream (needs torch). meta:
    preset, width, height, n_cameras (images rendered), pairs per image, batch_dims with batch dimensions, and
    for CUDA arrays uploaded (False: the last call's upload of the same, unchanged torch tensors was reused;
    cache=False always uploads). Every gsplat option is accepted at its default (rolling_shutter: None or
    gsplat's GLOBAL; far_plane: 1e10 or more); packed, channel_chunk and segmented at any value; any other
    value raises ValueError naming the option."""
def audit(source: _Path, candidates: Union[_Path, Sequence[_Path]], *, cameras: Optional[Sequence[Camera]] = None,
          orbit: Optional[int] = None, width: int = 960, height: int = 540, device: str = "auto",
          spz_frame: Union[str, Mapping[Union[str, os.PathLike], str]] = "rub", threshold: float = 40.0) -> Dict[str, Any]:
    """rgs-audit's measurement of one candidate path or a list of them against `source` on `cameras`, an orbit,
    or (neither given) the source's own cameras.json or views guessed from its content (views_note); each
    candidate's dict and the whole dict carry rgs-audit --json's verdict (mean PSNR in the verdict's metric,
    foreground where the source has background, >= threshold dB)."""

class ViewServer:
    """A running rgs-view server (roofgs.view()); in a notebook it displays the page inline (an iframe)."""
    url: str
    port: int
    token: str
    clients: int
    def stop(self) -> None: ...
    def __enter__(self) -> "ViewServer": ...
    def __exit__(self, *args: Any) -> None: ...
    def _repr_html_(self) -> str: ...

def view(scene: Union[Scene, _Path], scene2: Optional[Union[Scene, _Path]] = None, device: str = "auto",
         host: str = "127.0.0.1", port: int = 0, token: str = "", preset: str = "fastest", cameras: str = "",
         max_clients: int = 8, cuda_device: int = 0, height: int = 600) -> ViewServer:
    """Starts the rgs-view server in this process (docs/VIEWER.md) for `scene` (with `scene2`: the compare
    mode) and returns its handle. Only built with the viewer (RGS_BUILD_VIEWER); absent otherwise."""
