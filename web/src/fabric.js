// The fabric's measurements (report.json's `fabric`, psrig measure) as
// short lines: "7.1 wales/cm", "9.8 courses/cm", or per pixel without a
// pixel size.
export function fabricFigures(fabric) {
  if (!fabric || typeof fabric !== 'object') return [];
  const unit = fabric.units === 'per_pixel' || fabric.per_pixel ? '/px' : '/cm';
  const lines = [];
  for (const [key, label] of [
    ['wales_per_cm', 'wales'],
    ['courses_per_cm', 'courses'],
    ['ends_per_cm', 'ends'],
    ['picks_per_cm', 'picks'],
  ]) {
    const value = fabric[key];
    if (typeof value === 'number') lines.push(`${value.toFixed(unit === '/px' ? 4 : 1)} ${label}${unit}`);
  }
  if (typeof fabric.skew_deg === 'number') lines.push(`skew ${fabric.skew_deg.toFixed(1)}°`);
  return lines;
}
