// The harmonics descriptor's per-sphere signature: one workgroup per
// candidate, one invocation per ring of the 2B x 2B sampling grid
// (B = 32). Each invocation samples its ring, takes its Fourier
// coefficients for orders m < 16, then the workgroup sums Fejer-weighted
// Legendre values over the rings and keeps each degree's energy. Sample
// offsets and every trigonometric table come from the CPU (in f64), so
// the positions read are the CPU sampler's to the bit.

struct Params {
    // Cells of the grid read (voxels, or blocks of a pyramid level).
    dims: vec4<u32>,
    // u32 words between rows of the bit grid (level 0).
    row_words: u32,
    // 0: the bit grid; above: a pyramid level's occupancy bytes.
    level: u32,
    // Candidates in this dispatch, and workgroups along x.
    count: u32,
    groups_x: u32,
}

@group(0) @binding(0) var<storage, read> params: Params;
// Level 0: the bit grid's u64 words read as pairs of u32. Above: occupancy
// bytes packed four to a word.
@group(0) @binding(1) var<storage, read> cells: array<u32>;
// Per candidate: the centre in the sampler's frame (a voxel, or a fixed-point
// block position with 16 fractional bits).
@group(0) @binding(2) var<storage, read> origins: array<vec4<i32>>;
// Per sample (ring j, sector k at j * 64 + k): level 0, the lower corner's
// offset in voxels and its fraction; above, the offset in fixed point.
@group(0) @binding(3) var<storage, read> offsets: array<vec4<i32>>;
@group(0) @binding(4) var<storage, read> fractions: array<vec4<f32>>;
// (cos m phi_k, -sin m phi_k) at [k * 16 + m].
@group(0) @binding(5) var<storage, read> fourier: array<vec2<f32>>;
// Quadrature weight times the normalized Legendre value at [(m * 16 + l) * 64 + j].
@group(0) @binding(6) var<storage, read> legendre: array<f32>;
// Per candidate, the 16 degrees' energies.
@group(0) @binding(7) var<storage, read_write> signatures: array<f32>;

const RINGS: u32 = 64u;
const SECTORS: u32 = 64u;
const DEGREES: u32 = 16u;
const FIXED: u32 = 16u;

// Ring coefficients [ring * 16 + m], then per (m, l) energies.
var<workgroup> coefficients: array<vec2<f32>, 1024>;
var<workgroup> energies: array<f32, 256>;

// One cell of the grid read; outside it reads as empty, as on the CPU.
fn cell(p: vec3<i32>) -> f32 {
    let d = vec3<i32>(params.dims.xyz);
    if (any(p < vec3<i32>(0)) || any(p >= d)) {
        return 0.0;
    }
    let u = vec3<u32>(p);
    if (params.level == 0u) {
        let w = cells[(u.z * params.dims.y + u.y) * params.row_words + (u.x >> 5u)];
        return f32((w >> (u.x & 31u)) & 1u);
    }
    let i = (u.z * params.dims.y + u.y) * params.dims.x + u.x;
    return f32((cells[i >> 2u] >> ((i & 3u) * 8u)) & 255u);
}

// The CPU's trilinear interpolation, in its order of operations.
fn trilinear(i: vec3<i32>, f: vec3<f32>) -> f32 {
    let c0 = cell(i);
    let c1 = cell(i + vec3<i32>(1, 0, 0));
    let c2 = cell(i + vec3<i32>(0, 1, 0));
    let c3 = cell(i + vec3<i32>(1, 1, 0));
    let c4 = cell(i + vec3<i32>(0, 0, 1));
    let c5 = cell(i + vec3<i32>(1, 0, 1));
    let c6 = cell(i + vec3<i32>(0, 1, 1));
    let c7 = cell(i + vec3<i32>(1, 1, 1));
    let x00 = c0 + (c1 - c0) * f.x;
    let x10 = c2 + (c3 - c2) * f.x;
    let x01 = c4 + (c5 - c4) * f.x;
    let x11 = c6 + (c7 - c6) * f.x;
    let y0 = x00 + (x10 - x00) * f.y;
    let y1 = x01 + (x11 - x01) * f.y;
    return y0 + (y1 - y0) * f.z;
}

fn sample(origin: vec3<i32>, s: u32) -> f32 {
    let o = offsets[s].xyz;
    if (params.level == 0u) {
        return trilinear(origin + o, fractions[s].xyz);
    }
    let q = origin + o;
    let f = vec3<f32>(q & vec3<i32>(65535)) * (1.0 / 65536.0);
    return trilinear(q >> vec3<u32>(FIXED), f) * (1.0 / 255.0);
}

@compute @workgroup_size(64)
fn main(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) ring: u32) {
    let candidate = group.y * params.groups_x + group.x;
    // Uniform across the workgroup, so the barriers below stay valid.
    if (candidate >= params.count) {
        return;
    }
    let origin = origins[candidate].xyz;
    var acc: array<vec2<f32>, 16>;
    for (var m = 0u; m < DEGREES; m++) {
        acc[m] = vec2<f32>(0.0);
    }
    for (var k = 0u; k < SECTORS; k++) {
        let v = sample(origin, ring * SECTORS + k);
        for (var m = 0u; m < DEGREES; m++) {
            acc[m] += v * fourier[k * DEGREES + m];
        }
    }
    for (var m = 0u; m < DEGREES; m++) {
        coefficients[ring * DEGREES + m] = acc[m];
    }
    workgroupBarrier();
    for (var q = ring; q < DEGREES * DEGREES; q += RINGS) {
        let m = q / DEGREES;
        let l = q % DEGREES;
        var e = 0.0;
        if (l >= m) {
            var s = vec2<f32>(0.0);
            for (var r = 0u; r < RINGS; r++) {
                s += legendre[q * RINGS + r] * coefficients[r * DEGREES + m];
            }
            e = dot(s, s);
            if (m > 0u) {
                e *= 2.0;
            }
        }
        energies[q] = e;
    }
    workgroupBarrier();
    if (ring < DEGREES) {
        var e = 0.0;
        for (var m = 0u; m < DEGREES; m++) {
            e += energies[m * DEGREES + ring];
        }
        signatures[candidate * DEGREES + ring] = sqrt(e / (4.0 * 3.14159265358979));
    }
}
