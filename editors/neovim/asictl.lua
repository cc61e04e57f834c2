-- asictl for Neovim 0.11 and later: the language server (put this in init.lua)
vim.filetype.add({ extension = { asi = "asi", fb = "asi" } })
vim.lsp.config("asictl", {
  cmd = { "asictl", "lsp" }, -- add "--lib", "DIR" for block folders
  filetypes = { "asi" },
  root_markers = { ".git" },
})
vim.lsp.enable("asictl")
