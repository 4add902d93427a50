// Helpers every engine page shares (tests/engines/harness.mjs): float read-back encoding.

/** Float32 RGBA pixels read bottom row first (WebGL's readPixels) -> rows top first, base64. */
export function encodeRows(pixels, width, height) {
  const out = new Float32Array(width * height * 4);
  const row = width * 4;
  for (let y = 0; y < height; y++) out.set(pixels.subarray((height - 1 - y) * row, (height - y) * row), y * row);
  const bytes = new Uint8Array(out.buffer);
  let s = "";
  for (let i = 0; i < bytes.length; i += 0x8000) s += String.fromCharCode.apply(null, bytes.subarray(i, i + 0x8000));
  return btoa(s);
}
