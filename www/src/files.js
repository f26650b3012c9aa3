// Files the user picks or drops, made into what the package and three.js
// read: the format from the name, and a `.gltf` whose buffers live in `.bin`
// files beside it rewritten with the buffers inlined (the package reads bytes,
// not paths), so that a .gltf and its .bin can be dropped together.

export const FORMATS = ['glb', 'gltf', 'obj', 'ply', 'stl'];
const RESOURCE_EXTENSIONS = ['bin', 'png', 'jpg', 'jpeg', 'webp', 'ktx2'];

/** A file the viewer cannot use; its message is shown to the user as is. */
export class FileProblem extends Error {
  constructor(message) {
    super(message);
    this.name = 'FileProblem';
  }
}

function extension(name) {
  const dot = name.lastIndexOf('.');
  return dot < 0 ? '' : name.slice(dot + 1).toLowerCase();
}

/**
 * The model among `files` (File or {name, bytes}), with its resources.
 * Resolves to `{name, format, bytes}`; `bytes` is what both readers parse.
 */
export async function readModel(files) {
  const list = Array.from(files);
  if (list.length === 0) throw new FileProblem('No file was given.');
  const models = list.filter((f) => FORMATS.includes(extension(f.name)));
  if (models.length === 0) {
    const names = list.map((f) => f.name).join(', ');
    throw new FileProblem(
      `${names}: not a supported mesh file. Use .glb or .gltf (with its .bin), .obj, .ply or .stl.`,
    );
  }
  if (models.length > 1) {
    throw new FileProblem(`Several models at once (${models.map((f) => f.name).join(', ')}): give one.`);
  }
  const model = models[0];
  const unused = list.filter((f) => f !== model && !RESOURCE_EXTENSIONS.includes(extension(f.name)));
  if (unused.length) {
    throw new FileProblem(`${unused.map((f) => f.name).join(', ')}: not a mesh file or a glTF resource.`);
  }
  const format = extension(model.name);
  let bytes = await bytesOf(model);
  if (bytes.byteLength === 0) throw new FileProblem(`${model.name} is empty.`);
  if (format === 'gltf') bytes = await inlineBuffers(model.name, bytes, list);
  return { name: model.name, format, bytes };
}

/** The bytes of a File (a Blob) or of a `{name, bytes}` the page made itself. */
async function bytesOf(file) {
  if (file instanceof Blob) return new Uint8Array(await file.arrayBuffer());
  return file.bytes;
}

/** Replaces the external buffer URIs of a .gltf with data URIs of the files given with it. */
async function inlineBuffers(name, bytes, files) {
  let json;
  try {
    json = JSON.parse(new TextDecoder().decode(bytes));
  } catch (error) {
    throw new FileProblem(`${name} is not valid glTF JSON (${error.message}).`);
  }
  const buffers = Array.isArray(json?.buffers) ? json.buffers : [];
  let changed = false;
  for (const buffer of buffers) {
    if (typeof buffer?.uri !== 'string' || buffer.uri.startsWith('data:')) continue;
    const wanted = decodeURIComponent(buffer.uri.split(/[\\/]/).pop());
    const file = files.find((f) => f.name === wanted);
    if (!file) {
      throw new FileProblem(`${name} keeps its geometry in ${wanted}: pick or drop ${wanted} together with ${name}.`);
    }
    buffer.uri = `data:application/octet-stream;base64,${base64(await bytesOf(file))}`;
    changed = true;
  }
  // Images are not needed: the viewer draws its own material.
  return changed ? new TextEncoder().encode(JSON.stringify(json)) : bytes;
}

function base64(bytes) {
  let text = '';
  const chunk = 0x8000;
  for (let i = 0; i < bytes.length; i += chunk) {
    text += String.fromCharCode.apply(null, bytes.subarray(i, i + chunk));
  }
  return btoa(text);
}
