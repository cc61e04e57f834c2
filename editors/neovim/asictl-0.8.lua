-- asictl for Neovim 0.8 to 0.10: the language server (put this in init.lua)
vim.filetype.add({ extension = { asi = "asi", fb = "asi" } })
vim.api.nvim_create_autocmd("FileType", {
  pattern = "asi",
  callback = function(args)
    vim.lsp.start({
      name = "asictl",
      cmd = { "asictl", "lsp" }, -- add "--lib", "DIR" for block folders
      root_dir = vim.fs.dirname(vim.api.nvim_buf_get_name(args.buf)),
    })
  end,
})
-- the keys 0.11 maps by itself (0.10 maps K already)
vim.api.nvim_create_autocmd("LspAttach", {
  callback = function(args)
    local opts = { buffer = args.buf }
    vim.keymap.set("n", "K", vim.lsp.buf.hover, opts)
    vim.keymap.set("n", "gd", vim.lsp.buf.definition, opts)
    vim.keymap.set("n", "grr", vim.lsp.buf.references, opts)
  end,
})
