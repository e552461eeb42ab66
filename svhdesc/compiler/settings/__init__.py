"""svhdesc/compiler/settings"""
