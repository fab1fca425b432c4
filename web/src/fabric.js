// The fabric's measurements (report.json's `fabric`, psrig measure) as
// short lines: "knit", "7.1 wales/cm", "9.8 courses/cm", or per pixel
// without a pixel size.
export function fabricFigures(fabric) {
  if (!fabric || typeof fabric !== 'object') return [];
  const perPixel = fabric.units === 'per_px';
  const unit = perPixel ? 'px' : 'cm';
  const lines = [];
  if (fabric.construction && fabric.construction !== 'unknown')
    lines.push(fabric.structure ? `${fabric.construction} (${fabric.structure})` : fabric.construction);
  for (const name of ['wales', 'courses', 'ends', 'picks']) {
    const value = fabric[`${name}_per_${unit}`];
    if (typeof value === 'number') lines.push(`${value.toFixed(perPixel ? 4 : 1)} ${name}/${unit}`);
  }
  if (typeof fabric.skew_deg === 'number') lines.push(`skew ${fabric.skew_deg.toFixed(1)}°`);
  if (fabric.periodic === false) lines.push('no repeat found');
  return lines;
}
