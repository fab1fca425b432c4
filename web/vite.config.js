// Builds the catalogue into build/web/ (beside build/bin/psrigd, which
// serves it; installed to share/psrig/web). Relative asset paths so the
// pages work under any mount point.
import { fileURLToPath } from 'node:url';
import { defineConfig } from 'vite';

export default defineConfig({
  base: './',
  build: {
    outDir: fileURLToPath(new URL('../build/web', import.meta.url)),
    emptyOutDir: true,
    chunkSizeWarningLimit: 1024, // three.js alone is ~700 kB
  },
});
